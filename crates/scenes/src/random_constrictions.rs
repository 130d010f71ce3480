//! The last constriction on random surfaces (scene `random_constrictions`, issue 15): does the
//! paper's β (the leak rate of a seal vanishing as (L_c − L)^β, β = 3.45 for an isolated
//! saddle) carry over to randomly rough surfaces, and does it depend on the constriction's η?
//!
//! Inputs `constriction`: one `constriction` stage per realisation (each on its own
//! `selfaffine` stage: the pipeline's matrix over the Hurst exponents and the seeds, plus the
//! comparison set on the surface ensemble's surfaces); `ladder` (optional): the three lattices'
//! near-critical `ladder` stages, whose flux below L_c is drawn beside the surfaces'.
//! Realisations are grouped by their surface's spectrum (H, q_s: the `hurst`, `qs` provenance).
//!
//! Outputs:
//! - `random_constrictions.csv`, one row per realisation: the columns of
//!   [`kinds::constriction::SUMMARY`] but `wall_s` (seed, H, q_s, L_c, a_p, the constriction's
//!   node, gap, η of heights and gap, pressure-drop fraction just below L_c, β window fit with
//!   1σ and points, the constriction-gap exponent, rungs used; `eta_gap_nearest`: η of the gap
//!   at the rung nearest L_c where it is defined), `eta_gap_status` (the stencil of
//!   `eta_gap`, or why it is NaN: `contact_in_3x3` for a one-node throat whose neighbours touch)
//!   `beta_converged` (± `_err`, `_points`: the β fit over the used rungs with d ≥ 5e-3, the
//!   grid-converged range, [`beta_converged`]) and `running_beta` (the local slopes between
//!   neighbouring used rungs, farthest first,
//!   `;`-separated);
//! - `random_constrictions_summary.csv`: per group (H, q_s) mean, sd, sem and count of a_p, η,
//!   β, the gap exponent, the drop fraction and `beta_converged`, and the group's Pearson
//!   correlations of β and of `beta_converged` with ln η of the heights;
//! - `random_constrictions_hurst.csv`: per q_s and H the count, a_p (mean, sd, sem) and β (mean,
//!   sem); per q_s the correlation of a_p with H over the realisations and the least-squares
//!   slope da_p/dH with its standard error;
//! - figures `random_constrictions_map` (the first realisation's gap just below L_c, the
//!   constriction circled, and a zoom), `random_constrictions_flux` (flux against
//!   d = (L_c − L)/L_c, all realisations and the lattices' ladders, each normalised at d = 5e-2,
//!   with the paper's slope 3.45 and the one-node slope 3), `random_constrictions_beta_eta`
//!   (`beta_converged` against η) and `random_constrictions_ap_hurst` (a_p against H, mean ± sem).

use crate::scene::{OutputSpec, Outputs, Scene};
use analysis::sample::{mean_sd_sem as stats, ols_slope as slope, pearson};
use anyhow::Result;
use figures::scenes::constrictions::{
    ApSeries, BetaEtaFig, FluxCurve, FluxFig, LatticeCurve, MapFig, ap_hurst_figure,
    beta_eta_figure, flux_figure, map_figure,
};
use figures::style::Model;
use kinds::constriction::{ConstrictionRead, SUMMARY};
use kinds::ladder::LadderData;
use orchestrator::{InputSpec, Inputs, Params, StageContext};
use serde_json::json;
use store::ArtefactWriter;
use tables::Table;

/// The `random_constrictions` scene.
pub struct RandomConstrictions;

/// The smallest distance of the grid-converged β fit: on 4 surfaces (q_s = 8) solved on 2^9 and
/// 2^10 the local exponents agree to ≤ 0.05 for d ≥ 5e-3 and differ by up to 0.2 below
/// (README, "Seals on random surfaces"); nearer L_c the throat becomes one node again.
pub const D_CONVERGED: f64 = 5e-3;

/// The β fit over a realisation's used rungs with d ≥ [`D_CONVERGED`]: value, 1σ, points
/// (NaN, NaN, count where fewer than 3 rungs: the fit's error needs one degree of freedom).
pub fn beta_converged(r: &ConstrictionRead) -> (f64, f64, usize) {
    let (Some(d), Some(flux), Some(used)) = (
        r.rungs.get("d"),
        r.rungs.get("flux"),
        r.rungs.get("resolved"),
    ) else {
        return (f64::NAN, f64::NAN, 0);
    };
    let (ls, q): (Vec<f64>, Vec<f64>) = (0..d.len())
        .filter(|&i| used[i] > 0.5 && d[i] >= D_CONVERGED * (1.0 - 1e-12))
        .map(|i| (-d[i], flux[i]))
        .unzip();
    if ls.len() < 3 {
        return (f64::NAN, f64::NAN, ls.len());
    }
    match critical::scaling::fit_exponent(&ls, &q) {
        Ok(f) => (f.value, f.error, f.points),
        Err(_) => (f64::NAN, f64::NAN, ls.len()),
    }
}

/// The per-realisation table.
pub fn table(rows: &[ConstrictionRead]) -> Table {
    let mut t = Table::new();
    // every summary value but the wall time (no recomputation reproduces it; the artefact
    // keeps it)
    for k in SUMMARY.iter().filter(|k| **k != "wall_s") {
        t = t.with_f64(k, rows.iter().map(|r| r.get(k)));
    }
    let bc: Vec<(f64, f64, usize)> = rows.iter().map(beta_converged).collect();
    t.with_f64("beta_converged", bc.iter().map(|b| b.0))
        .with_f64("beta_converged_err", bc.iter().map(|b| b.1))
        .with_f64("beta_converged_points", bc.iter().map(|b| b.2 as f64))
        .with_str(
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
pub const SUMMARISED: [&str; 7] = [
    "a_p_raw",
    "eta_height",
    "eta_gap",
    "eta_gap_nearest",
    "beta",
    "gap_exponent",
    "drop_fraction",
];

/// The realisations' spectra (H, q_s), ascending in q_s then H, and each realisation's index
/// into them.
pub fn groups(rows: &[ConstrictionRead]) -> (Vec<(f64, f64)>, Vec<usize>) {
    let key = |r: &ConstrictionRead| (r.get("hurst"), r.get("qs"));
    let mut g: Vec<(f64, f64)> = Vec::new();
    for r in rows {
        let k = key(r);
        // exact comparison: the values are the stages' parameters, copied bit for bit
        if !g.iter().any(|x| same(*x, k)) {
            g.push(k);
        }
    }
    g.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.total_cmp(&b.0)));
    let idx = rows
        .iter()
        .map(|r| g.iter().position(|x| same(*x, key(r))).expect("a group"))
        .collect();
    (g, idx)
}

/// Column `c` of the realisations in group `k` (`idx` from [`groups`]).
fn group_column(rows: &[ConstrictionRead], idx: &[usize], k: usize, c: &str) -> Vec<f64> {
    rows.iter()
        .zip(idx)
        .filter(|(_, i)| **i == k)
        .map(|(r, _)| r.get(c))
        .collect()
}

/// Equal, NaN equal to NaN (a surface without provenance).
fn same(a: (f64, f64), b: (f64, f64)) -> bool {
    let eq = |x: f64, y: f64| x == y || (x.is_nan() && y.is_nan());
    eq(a.0, b.0) && eq(a.1, b.1)
}

/// A group's legend label.
pub fn group_label((h, qs): (f64, f64)) -> String {
    format!("$H$ = {h}, $q$_s = {qs}")
}

/// The summary table: per group, one row per summarised column, with the group's correlation
/// of β with ln η.
pub fn summary(rows: &[ConstrictionRead]) -> Table {
    let (g, idx) = groups(rows);
    let (mut hs, mut qs, mut qty) = (Vec::new(), Vec::new(), Vec::new());
    let (mut mean, mut sd, mut sem, mut count, mut corr, mut corr_c) = (
        Vec::new(),
        Vec::new(),
        Vec::new(),
        Vec::new(),
        Vec::new(),
        Vec::new(),
    );
    for (k, &(h, q)) in g.iter().enumerate() {
        let col = |c: &str| {
            rows.iter()
                .zip(&idx)
                .filter(|(_, i)| **i == k)
                .map(|(r, _)| r.get(c))
                .collect::<Vec<_>>()
        };
        let ln_eta: Vec<f64> = col("eta_height").iter().map(|e| e.ln()).collect();
        let r = pearson(&col("beta"), &ln_eta);
        let bc: Vec<f64> = rows
            .iter()
            .zip(&idx)
            .filter(|(_, i)| **i == k)
            .map(|(r, _)| beta_converged(r).0)
            .collect();
        let rc = pearson(&bc, &ln_eta);
        for c in SUMMARISED.iter().copied().chain(["beta_converged"]) {
            let v = if c == "beta_converged" {
                bc.clone()
            } else {
                col(c)
            };
            let (m, s, e, n) = stats(&v);
            hs.push(h);
            qs.push(q);
            qty.push(c.to_string());
            mean.push(m);
            sd.push(s);
            sem.push(e);
            count.push(n as f64);
            corr.push(r);
            corr_c.push(rc);
        }
    }
    Table::new()
        .with_f64("hurst", hs)
        .with_f64("qs", qs)
        .with_str("quantity", qty)
        .with_f64("mean", mean)
        .with_f64("sd", sd)
        .with_f64("sem", sem)
        .with_f64("count", count)
        .with_f64("corr_beta_ln_eta", corr)
        .with_f64("corr_beta_converged_ln_eta", corr_c)
}

/// a_p against H: the table (per q_s and H) and the figure's series (one per q_s).
pub fn hurst_table(rows: &[ConstrictionRead]) -> (Table, Vec<ApSeries>) {
    let (g, idx) = groups(rows);
    let mut qs_values: Vec<f64> = g.iter().map(|x| x.1).collect();
    qs_values.dedup_by(|a, b| same((0.0, *a), (0.0, *b)));
    let mut t: Vec<[f64; 13]> = Vec::new();
    let mut series = Vec::new();
    for q in qs_values {
        let in_q: Vec<&ConstrictionRead> = rows
            .iter()
            .filter(|r| same((0.0, r.get("qs")), (0.0, q)))
            .collect();
        let h_all: Vec<f64> = in_q.iter().map(|r| r.get("hurst")).collect();
        let a_all: Vec<f64> = in_q.iter().map(|r| r.get("a_p_raw")).collect();
        let r = pearson(&h_all, &a_all);
        let (b, be) = slope(&h_all, &a_all);
        let mut s = ApSeries {
            label: format!("$q$_s = {q}"),
            hurst: Vec::new(),
            mean: Vec::new(),
            sem: Vec::new(),
            points: h_all.iter().copied().zip(a_all.iter().copied()).collect(),
        };
        for (k, &(h, _)) in g
            .iter()
            .enumerate()
            .filter(|(_, x)| same((0.0, x.1), (0.0, q)))
        {
            let pick = |c: &str| group_column(rows, &idx, k, c);
            let (am, asd, asem, n) = stats(&pick("a_p_raw"));
            let (bm, _, bsem, _) = stats(&pick("beta"));
            let (em, _, esem, _) = stats(&pick("eta_height"));
            t.push([q, h, n as f64, am, asd, asem, bm, bsem, em, esem, r, b, be]);
            s.hurst.push(h);
            s.mean.push(am);
            s.sem.push(asem);
        }
        series.push(s);
    }
    let col = |k: usize| t.iter().map(|x| x[k]).collect::<Vec<_>>();
    let table = Table::new()
        .with_f64("qs", col(0))
        .with_f64("hurst", col(1))
        .with_f64("count", col(2))
        .with_f64("a_p_mean", col(3))
        .with_f64("a_p_sd", col(4))
        .with_f64("a_p_sem", col(5))
        .with_f64("beta_mean", col(6))
        .with_f64("beta_sem", col(7))
        .with_f64("eta_height_mean", col(8))
        .with_f64("eta_height_sem", col(9))
        .with_f64("corr_a_p_hurst", col(10))
        .with_f64("slope_a_p_hurst", col(11))
        .with_f64("slope_a_p_hurst_err", col(12));
    (table, series)
}

/// The lattices' ladder flux below L_c (finest grid; certified rungs: converged, percolating,
/// flow converged), d = −l.
pub fn lattice_curves(ladders: &[LadderData]) -> Vec<LatticeCurve> {
    ladders
        .iter()
        .filter_map(|lad| {
            let model = Model::ALL
                .into_iter()
                .find(|m| m.name() == lad.lattice.name())?;
            let level = lad.levels.last()?;
            let (d, flux): (Vec<f64>, Vec<f64>) = level
                .rungs
                .iter()
                .filter(|r| r.l < 0.0 && r.converged && r.percolating && r.flow_converged)
                .map(|r| (-r.l, r.flux))
                .unzip();
            Some(LatticeCurve { model, d, flux })
        })
        .collect()
}

impl Scene for RandomConstrictions {
    fn name(&self) -> &'static str {
        "random_constrictions"
    }
    fn doc(&self) -> &'static str {
        "the last constriction and β on random surfaces, per realisation and per spectrum (H, q_s) (tables, gap map with zoom, flux vs L_c − L beside the lattices' ladders, β vs η, a_p vs H)"
    }
    fn code_version(&self) -> u64 {
        4
    }
    fn inputs(&self, _params: &Params) -> Vec<InputSpec> {
        vec![
            InputSpec::many("constriction", &["constriction"])
                .doc("one constriction stage per realisation"),
            InputSpec::many("ladder", &["ladder"])
                .optional()
                .doc("the lattices' near-critical ladders (their flux below L_c for comparison)"),
        ]
    }
    fn outputs(&self, _params: &Params) -> Vec<OutputSpec> {
        vec![
            OutputSpec::table("table", "random_constrictions.csv"),
            OutputSpec::table("summary", "random_constrictions_summary.csv"),
            OutputSpec::table("hurst", "random_constrictions_hurst.csv"),
            OutputSpec::figure("map", "random_constrictions_map"),
            OutputSpec::figure("flux", "random_constrictions_flux"),
            OutputSpec::figure("beta_eta", "random_constrictions_beta_eta"),
            OutputSpec::figure("ap_hurst", "random_constrictions_ap_hurst"),
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
        let ladders: Vec<LadderData> = inputs
            .all("ladder")
            .iter()
            .map(LadderData::read)
            .collect::<Result<_>>()?;
        for r in &rows {
            if !r.get("beta").is_finite() {
                ctx.warn(format!(
                    "H = {}, q_s = {}, seed {}: no β (fewer than 2 resolved rungs)",
                    r.get("hurst"),
                    r.get("qs"),
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
                "$H$ = {}, $q$_s = {}, seed {}: $L$_c/$p$_{{fc}} = {:.4}, η = {:.2}",
                first.get("hurst"),
                first.get("qs"),
                first.get("seed"),
                first.get("l_c") / first.get("p_fc"),
                first.get("eta_height")
            ),
        })?;
        let (g, idx) = groups(&rows);
        let labels: Vec<String> = g.iter().map(|x| group_label(*x)).collect();
        let curves: Vec<FluxCurve> = rows
            .iter()
            .zip(&idx)
            .map(|(r, &k)| FluxCurve {
                group: k,
                d: r.rungs["d"].clone(),
                flux: r.rungs["flux"].clone(),
                resolved: r.rungs["resolved"].iter().map(|v| *v > 0.5).collect(),
            })
            .collect();
        let lattices = lattice_curves(&ladders);
        if lattices.is_empty() {
            ctx.warn("no lattice ladder input: the flux figure shows the surfaces only");
        }
        let flux = flux_figure(&FluxFig {
            groups: labels.clone(),
            curves,
            lattices,
        })?;
        let col = |k: &str| rows.iter().map(|r| r.get(k)).collect::<Vec<_>>();
        let bc: Vec<(f64, f64, usize)> = rows.iter().map(beta_converged).collect();
        let be = beta_eta_figure(&BetaEtaFig {
            groups: labels,
            group: idx.clone(),
            eta: col("eta_height"),
            beta: bc.iter().map(|b| b.0).collect(),
            beta_err: bc.iter().map(|b| b.1).collect(),
            beta_label: format!("β (fit over {D_CONVERGED} ≤ $d$ ≤ 0.05)"),
        })?;
        let (hurst, ap_series) = hurst_table(&rows);
        let ap = ap_hurst_figure(&ap_series)?;
        let per_group: Vec<serde_json::Value> = g
            .iter()
            .enumerate()
            .map(|(k, &(h, q))| {
                let pick = |c: &str| group_column(&rows, &idx, k, c);
                let (bm, bsd, bsem, bn) = stats(&pick("beta"));
                let (am, asd, asem, an) = stats(&pick("a_p_raw"));
                json!({
                    "hurst": h, "qs": q,
                    "beta": [bm, bsd, bsem, bn],
                    "a_p_raw": [am, asd, asem, an],
                })
            })
            .collect();
        Ok(Outputs::new()
            .table("table", table(&rows))
            .table("summary", summary(&rows))
            .table("hurst", hurst)
            .figure("map", map)
            .figure("flux", flux)
            .figure("beta_eta", be)
            .figure("ap_hurst", ap)
            .with_stats(json!({
                "realisations": rows.len(),
                "lattices": ladders.len(),
                "groups": per_group,
            })))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(h: f64, qs: f64, a_p: f64, beta: f64) -> ConstrictionRead {
        let summary = [("hurst", h), ("qs", qs), ("a_p_raw", a_p), ("beta", beta)]
            .into_iter()
            .map(|(k, v)| (k.to_string(), v))
            .collect();
        ConstrictionRead {
            summary,
            eta_gap_status: "eighth".into(),
            rungs: Default::default(),
            running_beta: Default::default(),
            running_gap: Default::default(),
            gap: None,
            cell: (1.0, 1.0),
        }
    }

    /// Groups by (H, q_s), ascending in q_s then H; per-H a_p means, the correlation and slope
    /// of a_p against H within one q_s (oracle: a_p = 0.3 + 0.2 H ± 0.01 exactly, so the slope
    /// is 0.2 and the per-H means are 0.3 + 0.2 H).
    #[test]
    fn groups_and_a_p_against_hurst() {
        let mut rows = Vec::new();
        for h in [0.8, 0.5, 0.65] {
            for e in [-0.01, 0.01] {
                rows.push(row(h, 8.0, 0.3 + 0.2 * h + e, 3.5));
            }
        }
        rows.push(row(0.8, 64.0, 0.46, 3.0));
        let (g, idx) = groups(&rows);
        assert_eq!(g, vec![(0.5, 8.0), (0.65, 8.0), (0.8, 8.0), (0.8, 64.0)]);
        assert_eq!(idx, vec![2, 2, 0, 0, 1, 1, 3]);
        let (t, series) = hurst_table(&rows);
        assert_eq!(series.len(), 2);
        assert_eq!(series[0].hurst, vec![0.5, 0.65, 0.8]);
        for (h, m) in series[0].hurst.iter().zip(&series[0].mean) {
            assert!((m - (0.3 + 0.2 * h)).abs() < 1e-12, "{h}: {m}");
        }
        assert_eq!(series[0].points.len(), 6);
        // the single-H group: no correlation with H
        let csv_q64 = String::from_utf8(tables::csv_bytes(&t).unwrap()).unwrap();
        let last = csv_q64.lines().last().unwrap().to_string();
        assert!(
            last.starts_with("64.0,0.8,1.0,") && last.ends_with("NaN,NaN,NaN"),
            "{last}"
        );
        let csv = String::from_utf8(tables::csv_bytes(&t).unwrap()).unwrap();
        assert_eq!(csv.lines().count(), 1 + 4, "{csv}");
        let (s, _) = slope(
            &rows[..6].iter().map(|r| r.get("hurst")).collect::<Vec<_>>(),
            &rows[..6]
                .iter()
                .map(|r| r.get("a_p_raw"))
                .collect::<Vec<_>>(),
        );
        assert!((s - 0.2).abs() < 1e-9, "{s}");
        let sum = String::from_utf8(tables::csv_bytes(&summary(&rows)).unwrap()).unwrap();
        assert_eq!(sum.lines().count(), 1 + 4 * (SUMMARISED.len() + 1), "{sum}");
    }

    /// Oracle: flux = d^3.6 on d ≥ 5e-3 and a one-node tail ∝ d³ below (continuous at 5e-3):
    /// the converged fit is 3.6 exactly (to rounding), whatever the tail; an unused rung in the
    /// range is left out; fewer than 3 rungs give NaN.
    #[test]
    fn beta_converged_fits_the_grid_converged_rungs_only() {
        let d = vec![5e-2, 2e-2, 1e-2, 5e-3, 2e-3, 1e-3];
        let flux: Vec<f64> = d
            .iter()
            .map(|x: &f64| {
                if *x >= 5e-3 {
                    x.powf(3.6)
                } else {
                    5e-3f64.powf(3.6) * (x / 5e-3).powi(3)
                }
            })
            .collect();
        let mut r = row(0.8, 8.0, 0.4, 3.3);
        r.rungs.insert("d".into(), d.clone());
        r.rungs.insert("flux".into(), flux.clone());
        r.rungs.insert("resolved".into(), vec![1.0; 6]);
        let (b, _, n) = beta_converged(&r);
        assert_eq!(n, 4);
        assert!((b - 3.6).abs() < 1e-9, "{b}");
        r.rungs
            .insert("resolved".into(), vec![1.0, 0.0, 1.0, 1.0, 1.0, 1.0]);
        let (b, _, n) = beta_converged(&r);
        assert_eq!(n, 3);
        assert!((b - 3.6).abs() < 1e-9, "{b}");
        r.rungs
            .insert("resolved".into(), vec![1.0, 0.0, 0.0, 1.0, 1.0, 1.0]);
        let (b, _, n) = beta_converged(&r);
        assert!(b.is_nan() && n == 2);
    }
}
