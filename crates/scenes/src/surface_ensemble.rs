//! An ensemble of random surfaces (scene `surface_ensemble`): per seed, the fluid percolation
//! load L_p (the load above which the fluid percolates along no axis; midpoint of the
//! bisection bracket, in E* h0/λ and as a fraction of p_fc) and the contact area a_p there
//! (raw and perimeter-corrected), also along x and y alone; then the ensemble mean, standard
//! deviation and standard error of the mean.
//!
//! Inputs `leakage`: one `leakage` stage (with `percolation = true`) per seed, each on its own
//! `selfaffine` stage (the pipeline's matrix expansion over the seeds).
//!
//! Output `surface_ensemble.csv`: columns `seed` (text: the seed, then `mean`, `sd`, `sem`),
//! `l_p`, `l_p_over_p_fc`, `a_p`, `a_p_corrected`, `a_p_x`, `a_p_y`; the summary rows hold the
//! statistic of each column over the seeds (sd with n − 1; NaN for a single seed).

use crate::scene::{OutputSpec, Outputs, Scene};
use anyhow::{Result, anyhow};
use kinds::leakage::LeakageRead;
use orchestrator::{InputSpec, Inputs, Params, StageContext};
use serde_json::json;
use store::ArtefactWriter;
use tables::Table;

/// The `surface_ensemble` scene.
pub struct SurfaceEnsemble;

/// Column names of the per-seed values, in table order.
pub const VALUE_COLUMNS: [&str; 6] = [
    "l_p",
    "l_p_over_p_fc",
    "a_p",
    "a_p_corrected",
    "a_p_x",
    "a_p_y",
];

/// One seed's values, in [`VALUE_COLUMNS`] order.
pub fn seed_values(l: &LeakageRead) -> Result<[f64; 6]> {
    let p = l.percolation.as_ref().ok_or_else(|| {
        anyhow!("a leakage input has no percolation load: set `percolation = true`")
    })?;
    let any = &p["any"];
    Ok([
        any.load,
        any.load / l.p_fc,
        any.a_p,
        any.a_p_corrected,
        p["x"].a_p,
        p["y"].a_p,
    ])
}

/// Mean, sample standard deviation (n − 1) and standard error of the mean.
pub fn mean_sd_sem(v: &[f64]) -> (f64, f64, f64) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    if v.len() < 2 {
        return (mean, f64::NAN, f64::NAN);
    }
    let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    (mean, sd, sd / n.sqrt())
}

/// The table: one row per seed, then mean, sd, sem.
pub fn table(seeds: &[String], rows: &[[f64; 6]]) -> Table {
    let mut labels = seeds.to_vec();
    labels.extend(["mean", "sd", "sem"].map(String::from));
    let mut t = Table::new().with_str("seed", labels);
    for (k, name) in VALUE_COLUMNS.iter().enumerate() {
        let col: Vec<f64> = rows.iter().map(|r| r[k]).collect();
        let (m, sd, sem) = mean_sd_sem(&col);
        t = t.with_f64(name, col.into_iter().chain([m, sd, sem]));
    }
    t
}

impl Scene for SurfaceEnsemble {
    fn name(&self) -> &'static str {
        "surface_ensemble"
    }
    fn doc(&self) -> &'static str {
        "per-seed L_p and a_p of random surfaces and the ensemble mean ± spread (table)"
    }
    fn code_version(&self) -> u64 {
        1
    }
    fn inputs(&self, _params: &Params) -> Vec<InputSpec> {
        vec![InputSpec::many("leakage", &["leakage"]).doc("one leakage stage per seed")]
    }
    fn outputs(&self, _params: &Params) -> Vec<OutputSpec> {
        vec![OutputSpec::table("ensemble", "surface_ensemble.csv")]
    }
    fn render(
        &self,
        _ctx: &mut StageContext,
        _params: &Params,
        inputs: &Inputs,
        _out: &mut ArtefactWriter,
    ) -> Result<Outputs> {
        let mut seeds = Vec::new();
        let mut rows = Vec::new();
        for (i, r) in inputs.all("leakage").iter().enumerate() {
            let l = LeakageRead::read(r)?;
            seeds.push(l.seed.map_or(format!("input {i}"), |s| s.to_string()));
            rows.push(seed_values(&l)?);
        }
        let a_p: Vec<f64> = rows.iter().map(|r| r[2]).collect();
        let (m, sd, sem) = mean_sd_sem(&a_p);
        Ok(Outputs::new()
            .table("ensemble", table(&seeds, &rows))
            .with_stats(json!({"seeds": seeds.len(), "a_p_mean": m, "a_p_sd": sd, "a_p_sem": sem})))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Oracle: mean 2, sd √(((1−2)² + 0 + (3−2)²)/2) = 1, sem 1/√3.
    #[test]
    fn statistics_of_three_values() {
        let (m, sd, sem) = mean_sd_sem(&[1.0, 2.0, 3.0]);
        assert_eq!(m, 2.0);
        assert!((sd - 1.0).abs() < 1e-15);
        assert!((sem - 1.0 / 3f64.sqrt()).abs() < 1e-15);
        assert!(mean_sd_sem(&[0.4]).1.is_nan());
        let t = table(&["1".into(), "2".into()], &[[1.0; 6], [3.0; 6]]);
        assert_eq!(t.n_rows(), 5);
        assert_eq!(t.f64("a_p").unwrap()[2], 2.0);
    }
}
