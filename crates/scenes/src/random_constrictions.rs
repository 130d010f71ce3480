//! The last constriction on random surfaces (scene `random_constrictions`, issue 15): does the
//! paper's β (the leak rate of a seal vanishing as (L_c − L)^β, β = 3.45 for an isolated
//! saddle) carry over to randomly rough surfaces, and does it depend on the constriction's η?
//!
//! Inputs `constriction`: one `constriction` stage per realisation (each on its own
//! `selfaffine` stage: the pipeline's matrix over the seeds).
//!
//! Outputs:
//! - `random_constrictions.csv`, one row per realisation: the columns of
//!   [`kinds::constriction::SUMMARY`] but `wall_s` (seed, L_c, a_p, the constriction's node, gap, η of
//!   heights and gap, pressure-drop fraction just below L_c, β window fit with 1σ and points,
//!   the constriction-gap exponent, rungs used), `eta_gap_status` (the stencil of `eta_gap`, or
//!   why it is NaN: `contact_in_3x3` for a one-node throat whose neighbours touch) and
//!   `running_beta` (the local slopes between
//!   neighbouring used rungs, farthest first, `;`-separated);
//! - `random_constrictions_summary.csv`: mean, sd, sem and count over the realisations of a_p,
//!   η, β, the gap exponent and the drop fraction, and the Pearson correlation of β with ln η;
//! - figures `random_constrictions_map` (the first realisation's gap just below L_c, the
//!   constriction circled, and a zoom), `random_constrictions_flux` (flux against
//!   d = (L_c − L)/L_c, all realisations, with the paper's slope 3.45 and the one-node slope 3),
//!   `random_constrictions_beta_eta` (β against η).

use crate::scene::{OutputSpec, Outputs, Scene};
use anyhow::Result;
use figures::scenes::constrictions::{
    BetaEtaFig, FluxCurve, MapFig, beta_eta_figure, flux_figure, map_figure,
};
use kinds::constriction::{ConstrictionRead, SUMMARY};
use orchestrator::{InputSpec, Inputs, Params, StageContext};
use serde_json::json;
use store::ArtefactWriter;
use tables::Table;

/// The `random_constrictions` scene.
pub struct RandomConstrictions;

/// Mean, sample sd (n − 1; NaN for one value) and sem of the finite values, and their count.
pub fn stats(v: &[f64]) -> (f64, f64, f64, usize) {
    let v: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    let n = v.len() as f64;
    if v.is_empty() {
        return (f64::NAN, f64::NAN, f64::NAN, 0);
    }
    let m = v.iter().sum::<f64>() / n;
    if v.len() < 2 {
        return (m, f64::NAN, f64::NAN, 1);
    }
    let sd = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    (m, sd, sd / n.sqrt(), v.len())
}

/// Pearson correlation of the pairs where both are finite (NaN with fewer than 3).
pub fn pearson(a: &[f64], b: &[f64]) -> f64 {
    let (x, y): (Vec<f64>, Vec<f64>) = a
        .iter()
        .zip(b)
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .map(|(x, y)| (*x, *y))
        .unzip();
    if x.len() < 3 {
        return f64::NAN;
    }
    let (mx, sx, _, _) = stats(&x);
    let (my, sy, _, _) = stats(&y);
    let n = x.len() as f64;
    x.iter()
        .zip(&y)
        .map(|(a, b)| (a - mx) * (b - my))
        .sum::<f64>()
        / ((n - 1.0) * sx * sy)
}

/// The per-realisation table.
pub fn table(rows: &[ConstrictionRead]) -> Table {
    let mut t = Table::new();
    // every summary value but the wall time (no recomputation reproduces it; the artefact
    // keeps it)
    for k in SUMMARY.iter().filter(|k| **k != "wall_s") {
        t = t.with_f64(k, rows.iter().map(|r| r.get(k)));
    }
    t.with_str(
        "eta_gap_status",
        rows.iter().map(|r| r.eta_gap_status.clone()),
    )
    .with_str(
        "running_beta",
        rows.iter().map(|r| {
            r.running_beta
                .value
                .iter()
                .map(|v| format!("{v:.4}"))
                .collect::<Vec<_>>()
                .join(";")
        }),
    )
}

/// Columns summarised over the realisations.
pub const SUMMARISED: [&str; 6] = [
    "a_p_raw",
    "eta_height",
    "eta_gap",
    "beta",
    "gap_exponent",
    "drop_fraction",
];

/// The summary table: one row per summarised column, and the correlation of β with ln η.
pub fn summary(rows: &[ConstrictionRead]) -> (Table, f64) {
    let col = |k: &str| rows.iter().map(|r| r.get(k)).collect::<Vec<_>>();
    let s: Vec<(f64, f64, f64, usize)> = SUMMARISED.iter().map(|k| stats(&col(k))).collect();
    let ln_eta: Vec<f64> = col("eta_height").iter().map(|e| e.ln()).collect();
    let corr = pearson(&col("beta"), &ln_eta);
    let t = Table::new()
        .with_str("quantity", SUMMARISED.iter().map(|s| s.to_string()))
        .with_f64("mean", s.iter().map(|v| v.0))
        .with_f64("sd", s.iter().map(|v| v.1))
        .with_f64("sem", s.iter().map(|v| v.2))
        .with_f64("count", s.iter().map(|v| v.3 as f64))
        .with_f64("corr_beta_ln_eta", s.iter().map(|_| corr));
    (t, corr)
}

impl Scene for RandomConstrictions {
    fn name(&self) -> &'static str {
        "random_constrictions"
    }
    fn doc(&self) -> &'static str {
        "the last constriction and β on random surfaces, per realisation and over the ensemble (table, gap map with zoom, flux vs L_c − L, β vs η)"
    }
    fn code_version(&self) -> u64 {
        1
    }
    fn inputs(&self, _params: &Params) -> Vec<InputSpec> {
        vec![
            InputSpec::many("constriction", &["constriction"])
                .doc("one constriction stage per realisation"),
        ]
    }
    fn outputs(&self, _params: &Params) -> Vec<OutputSpec> {
        vec![
            OutputSpec::table("table", "random_constrictions.csv"),
            OutputSpec::table("summary", "random_constrictions_summary.csv"),
            OutputSpec::figure("map", "random_constrictions_map"),
            OutputSpec::figure("flux", "random_constrictions_flux"),
            OutputSpec::figure("beta_eta", "random_constrictions_beta_eta"),
        ]
    }
    fn fields_read(&self) -> u64 {
        1
    }
    fn render(
        &self,
        ctx: &mut StageContext,
        _params: &Params,
        inputs: &Inputs,
        _out: &mut ArtefactWriter,
    ) -> Result<Outputs> {
        let rows: Vec<ConstrictionRead> = inputs
            .all("constriction")
            .iter()
            .map(ConstrictionRead::read)
            .collect::<Result<_>>()?;
        anyhow::ensure!(!rows.is_empty(), "no constriction inputs");
        for r in &rows {
            if !r.get("beta").is_finite() {
                ctx.warn(format!(
                    "seed {}: no β (fewer than 2 resolved rungs)",
                    r.get("seed")
                ));
            }
        }
        let first = &rows[0];
        let gap = first
            .gap
            .clone()
            .ok_or_else(|| anyhow::anyhow!("the first constriction input has no map/gap"))?;
        let (lx, ly) = first.cell;
        let map = map_figure(&MapFig {
            gap,
            lx,
            ly,
            at: (first.get("x"), first.get("y")),
            zoom: 0.05 * lx.max(ly),
            title: format!(
                "seed {}: $L$_c/$p$_{{fc}} = {:.4}, η = {:.2}",
                first.get("seed"),
                first.get("l_c") / first.get("p_fc"),
                first.get("eta_height")
            ),
        })?;
        let curves: Vec<FluxCurve> = rows
            .iter()
            .map(|r| FluxCurve {
                label: format!("seed {}", r.get("seed")),
                d: r.rungs["d"].clone(),
                flux: r.rungs["flux"].clone(),
                resolved: r.rungs["resolved"].iter().map(|v| *v > 0.5).collect(),
            })
            .collect();
        let flux = flux_figure(&curves)?;
        let col = |k: &str| rows.iter().map(|r| r.get(k)).collect::<Vec<_>>();
        let be = beta_eta_figure(&BetaEtaFig {
            eta: col("eta_height"),
            beta: col("beta"),
            beta_err: col("beta_err"),
        })?;
        let (sum, corr) = summary(&rows);
        let (bm, bsd, bsem, bn) = stats(&col("beta"));
        let (am, asd, asem, _) = stats(&col("a_p_raw"));
        Ok(Outputs::new()
            .table("table", table(&rows))
            .table("summary", sum)
            .figure("map", map)
            .figure("flux", flux)
            .figure("beta_eta", be)
            .with_stats(json!({
                "realisations": rows.len(),
                "beta": [bm, bsd, bsem, bn],
                "a_p_raw": [am, asd, asem],
                "corr_beta_ln_eta": corr,
            })))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Oracles: mean 2, sd 1, sem 1/√3 of (1, 2, 3); a perfect linear relation correlates 1,
    /// an anti-linear one −1; NaN is skipped.
    #[test]
    fn statistics_and_correlation() {
        let (m, sd, sem, n) = stats(&[1.0, 2.0, f64::NAN, 3.0]);
        assert_eq!((m, n), (2.0, 3));
        assert!((sd - 1.0).abs() < 1e-15 && (sem - 1.0 / 3f64.sqrt()).abs() < 1e-15);
        assert!(stats(&[0.3]).1.is_nan());
        let a = [1.0, 2.0, 4.0, 7.0];
        let b: Vec<f64> = a.iter().map(|x| 3.0 - 2.0 * x).collect();
        assert!((pearson(&a, &b) + 1.0).abs() < 1e-12);
        assert!((pearson(&a, &a) - 1.0).abs() < 1e-12);
        assert!(pearson(&a[..2], &b[..2]).is_nan());
    }
}
