//! `exponents`: the near-critical exponents ζ, υ, χ and β of each model from its `ladder`
//! (crates/critical/src/scaling.rs): the window fit over the paper's 0.002 ≤ |l| ≤ 0.02
//! ([`WINDOW`]), each with an error bar from the fit and from the spread across the ladder's
//! grid resolutions; the asymptotic estimate (l → 0) with corrections to scaling from the finest
//! grid's grid-converged rungs, extended below by the model's refined ladder where one is given
//! and grid-converged ([`asymptotic`], "The combined ladder"); υ and χ from below also from the
//! refined ladders' neck lengths ([`asymptotic`], "The neck rows"); and the identity
//! β = 3ζ + υ − χ checked both ways. The table `exponents.csv` is built by [`table`]; the
//! artefact is read by [`read`].
//!
//! # Per grid
//! - ζ: the gap at the saddle node against |l| (l < 0), power law in log–log; also with L_c free
//!   (`A (L_c − L)^ζ`, [`analysis::fit_saddle_gap`]) as a check of the L_c used (`zeta_lc_free`);
//! - υ: the open channel's half-width r_c (square-root onset of the contact pressure across the
//!   channel) against |l| (l < 0);
//! - χ: the blocked channel's half-length a (Hertzian pressure along the channel axis) against l
//!   (l > 0);
//! - β: the flux through the cell against |l| = (L_c − L)/L_c (l < 0, fluid percolating, flow
//!   solve converged).
//!
//! Only the rungs with |l| in [`WINDOW`] enter these fits (a ladder may extend far beyond it:
//! those rungs are for the running exponents and the asymptotic estimate).
//! A rung whose measurement fails (channel not resolved, contact outside the window, fit
//! failure) is left out of that fit with a warning; a fit needs 2 rungs (its error needs 3).
//!
//! # Per model
//! The finest grid with a fit gives the value and the fit error (1σ, scaled by the reduced χ²);
//! `grid_spread` is the largest difference to the other grids' values (NaN with one grid);
//! `error` = sqrt(fit² + spread²). `beta_identity` = 3ζ + υ − χ with the errors combined in
//! quadrature, compared with the flux's β (`beta_identity_diff`, in σ of both).
//!
//! # Artefact
//! Attribute `models` (JSON list); per model `model/<lattice>`: attributes `<e>`,
//! `<e>_fit_error`, `<e>_grid_spread`, `<e>_error`, `<e>_n`, `<e>_points`, `<e>_prefactor`
//! for e in zeta, upsilon, chi, beta (NaN when no grid gave a fit), the asymptotic estimates
//! `<e>_asymptotic_<field>` for e in zeta, upsilon, chi, beta, beta_identity (fields
//! [`asymptotic::Asymptotic::FIELDS`]; NaN without an estimate; from the combined ladder), the
//! uniform-only ones `<e>_uniform_asymptotic_<field>` (e also `beta_identity`), the string
//! `<e>_asymptotic_method` (e in zeta, upsilon, chi, beta), `zeta_lc_free`,
//! `zeta_lc_free_error`, `l_c_fit`, `beta_identity`, `beta_identity_error`, `eta`; the neck
//! estimates `<r>_asymptotic_<field>` and `<r>_asymptotic_method` for r in `upsilon_neck`,
//! `chi_below` ([`NECK_ROWS`]) and `beta_identity_neck_asymptotic_<field>`; per grid
//! `model/<lattice>/level/<n>`: the same fit attributes and datasets ([`OpenRow`]) `l_open`,
//! `load_open`, `saddle_gap`, `half_width`, `half_width_error`, `flux` and ([`BlockedRow`])
//! `l_blocked`, `half_length`, `half_length_error` (NaN where a measurement failed).
//!
//! Figure 6's bottom-left panel reads the same artefact as its `ladder` input (through
//! [`read_flux_curve`] and [`read_pooled_beta`]): per model ([`FluxPoint`])
//! `ladder/<lattice>/distance` ((L_c − L)/L_c of the finest grid's rungs below L_c where the
//! fluid flows) and `ladder/<lattice>/flux` (the flux normalised by its value at the largest
//! distance, [`normalised_flux`]); root attributes
//! `beta`, `beta_err`, `beta_prefactor` of a power law fitted to all models' points in
//! [`WINDOW`] together ([`pooled_beta`]; the per-model β are the `model/<lattice>` attributes).
//! With the model's refined ladder: `ladder/<lattice>/refined/{distance, flux}` (its flux,
//! `critical::refined_flow`, rungs below l = 0 with a flux, normalised to continue the uniform
//! curve: multiplied so that it equals the uniform normalised flux at the combined ladder's
//! junction, or, without one, at the largest distance both share; not written without a
//! common rung); with a deep refined ladder chained below it (input `deep`),
//! `ladder/<lattice>/refined_deep/{distance, flux}` likewise continuing the refined curve at the
//! deep ladder's junction), and per model with an asymptotic β the attributes `beta_asymptotic`,
//! `beta_asymptotic_error`, `beta_asymptotic_distance`, `beta_asymptotic_flux` on
//! `ladder/<lattice>` (the slope and the point of the drawn curves at the estimate's smallest
//! distance, through which Figure 6 draws it).

pub mod asymptotic;
mod io;
mod model;
pub mod table;

use io::group_notes;
pub use io::{
    AsymptoticSlope, BlockedRow, FluxCurve, FluxPoint, OpenRow, read, read_asymptotic_slope,
    read_flux_curve, read_pooled_beta, read_refined_flux_curve,
};

use crate::ladder::{LadderData, LadderLevel};
use crate::refined_chain::{Linked, chain_of};
use crate::refined_neck::{self, LinkedNeck, NeckMeasure};
use anyhow::{Result, bail};
use asymptotic::Asymptotic;
use critical::scaling::{
    EdgeOptions, ExponentFit, blocked_half_length, fit_exponent, open_half_width,
};
use orchestrator::{InputSpec, Inputs, ParamSpec, ParamType, StageContext, StageReport, TypedKind};
use serde::Deserialize;
use serde_json::json;
use store::ArtefactWriter;

/// The `exponents` stage kind.
pub struct ExponentsKind;

/// Bump when the artefact's content changes for the same inputs.
pub const CODE_VERSION: u64 = 8;

/// The paper's fitting window of |l| (inclusive; a relative 1e-9 of slack for rounding).
pub const WINDOW: (f64, f64) = (0.002, 0.02);

/// Whether a reduced load is inside [`WINDOW`].
pub fn in_window(l: f64) -> bool {
    let a = l.abs();
    a >= WINDOW.0 * (1.0 - 1e-9) && a <= WINDOW.1 * (1.0 + 1e-9)
}

/// The exponents, in table order.
pub const NAMES: [&str; 4] = ["zeta", "upsilon", "chi", "beta"];

/// The asymptotic estimates from the refined ladders' neck lengths ([`asymptotic::estimate_neck`]),
/// in table order: (row and attribute name, the neck length, index of the exponent in
/// [`NAMES`] whose paper value, conjecture and verdict rule apply): υ from the rms width W_2,
/// χ from below from the rise length.
pub const NECK_ROWS: [(&str, NeckMeasure, usize); 2] = [
    ("upsilon_neck", NeckMeasure::WidthRms, 1),
    ("chi_below", NeckMeasure::RiseLength, 2),
];

/// The paper's values (Dapp & Müser 2015): ζ, υ, χ ± 0.01, β = 3.45 (no error given).
pub const PAPER: [(f64, f64); 4] = [(1.20, 0.01), (0.45, 0.01), (0.60, 0.01), (3.45, f64::NAN)];

/// The paper's conjectured exact values 6/5, 9/20, 3/5 and 3·6/5 + 9/20 − 3/5 = 69/20.
pub const CONJECTURED: [(f64, &str); 4] = [
    (6.0 / 5.0, "6/5"),
    (9.0 / 20.0, "9/20"),
    (3.0 / 5.0, "3/5"),
    (69.0 / 20.0, "69/20"),
];

/// Greek symbol of an exponent name.
pub fn symbol(name: &str) -> &'static str {
    match name {
        "zeta" => "ζ",
        "upsilon" => "υ",
        "chi" => "χ",
        "beta" => "β",
        _ => "?",
    }
}

/// Measurements on one grid.
#[derive(Clone, Debug, Default)]
pub struct LevelMeasure {
    /// Grid exponent.
    pub n: u32,
    /// Reduced loads l < 0.
    pub l_open: Vec<f64>,
    /// Loads (E* h0/λ) of those rungs.
    pub load_open: Vec<f64>,
    /// Gap at the saddle node (h0).
    pub saddle_gap: Vec<f64>,
    /// Open half-width r_c (λ) and its fit error.
    pub half_width: Vec<(f64, f64)>,
    /// Flux (NaN where the fluid does not percolate).
    pub flux: Vec<f64>,
    /// Conductivity along the channel and along the other grid axis (NaN where the fluid does
    /// not percolate that way or the flow solve did not converge).
    pub conductivity: Vec<(f64, f64)>,
    /// Reduced loads l > 0.
    pub l_blocked: Vec<f64>,
    /// Blocked half-length a (λ) and its fit error.
    pub half_length: Vec<(f64, f64)>,
}

/// Measures one ladder grid; failures become NaN and a note.
pub fn measure(level: &LadderLevel, opts: &EdgeOptions, notes: &mut Vec<String>) -> LevelMeasure {
    let mut m = LevelMeasure {
        n: level.n,
        ..Default::default()
    };
    for r in &level.rungs {
        if !r.converged {
            notes.push(format!(
                "n = {}, l = {}: contact solve not converged, left out",
                level.n, r.l
            ));
            continue;
        }
        if r.l < 0.0 {
            m.l_open.push(r.l);
            m.load_open.push(r.load);
            let g = r.window.saddle_gap();
            m.saddle_gap.push(if g > 0.0 { g } else { f64::NAN });
            m.half_width.push(match open_half_width(&r.window, opts) {
                Ok(e) => (e.r, e.r_error),
                Err(e) => {
                    notes.push(format!("n = {}, l = {}: open width: {e}", level.n, r.l));
                    (f64::NAN, f64::NAN)
                }
            });
            m.flux
                .push(if r.percolating && r.flux > 0.0 && r.flow_converged {
                    r.flux
                } else {
                    if r.percolating && !r.flow_converged {
                        notes.push(format!(
                            "n = {}, l = {}: flow solve not converged, flux left out",
                            level.n, r.l
                        ));
                    }
                    f64::NAN
                });
            let along = if r.percolating && r.flow_converged {
                r.conductivity
            } else {
                f64::NAN
            };
            m.conductivity.push((along, r.conductivity_across));
        } else if r.l > 0.0 {
            m.l_blocked.push(r.l);
            m.half_length.push(match blocked_half_length(&r.window) {
                Ok(e) => (e.r, e.r_error),
                Err(e) => {
                    notes.push(format!("n = {}, l = {}: blocked length: {e}", level.n, r.l));
                    (f64::NAN, f64::NAN)
                }
            });
        }
    }
    m
}

/// The four exponent fits of one grid (in [`NAMES`] order), over the rungs in [`WINDOW`].
pub fn level_fits(m: &LevelMeasure) -> [Result<ExponentFit, String>; 4] {
    let pick = |ls: &[f64], ys: &mut dyn Iterator<Item = f64>| -> (Vec<f64>, Vec<f64>) {
        ls.iter()
            .zip(ys)
            .filter(|(l, _)| in_window(**l))
            .map(|(l, y)| (*l, y))
            .unzip()
    };
    let (lg, g) = pick(&m.l_open, &mut m.saddle_gap.iter().copied());
    let (lw, w) = pick(&m.l_open, &mut m.half_width.iter().map(|v| v.0));
    let (la, a) = pick(&m.l_blocked, &mut m.half_length.iter().map(|v| v.0));
    let (lq, q) = pick(&m.l_open, &mut m.flux.iter().copied());
    [
        fit_exponent(&lg, &g),
        fit_exponent(&lw, &w),
        fit_exponent(&la, &a),
        fit_exponent(&lq, &q),
    ]
}

/// Figure 6's bottom-left points of one grid: (L_c − L)/L_c = |l| for the rungs below L_c where
/// the fluid flows, and the flux normalised by its value at the largest such |l|; ascending |l|.
pub fn normalised_flux(m: &LevelMeasure) -> (Vec<f64>, Vec<f64>) {
    let mut pts: Vec<(f64, f64)> = m
        .l_open
        .iter()
        .zip(&m.flux)
        .filter(|(_, q)| q.is_finite() && **q > 0.0)
        .map(|(l, q)| (l.abs(), *q))
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let Some(&(_, q0)) = pts.last() else {
        return (Vec::new(), Vec::new());
    };
    pts.iter().map(|(l, q)| (*l, q / q0)).unzip()
}

/// A power law fitted to the normalised points of all models together, over the distances in
/// [`WINDOW`] like every window fit (a ladder may reach far below it; those rungs are drawn, not
/// fitted): (β, 1σ or NaN without a degree of freedom, prefactor). None with fewer than two
/// points in the window.
pub fn pooled_beta(points: &[(Vec<f64>, Vec<f64>)]) -> Option<(f64, f64, f64)> {
    let (x, y): (Vec<f64>, Vec<f64>) = points
        .iter()
        .flat_map(|p| p.0.iter().copied().zip(p.1.iter().copied()))
        .filter(|&(d, _)| in_window(d))
        .unzip();
    if x.len() < 2 {
        return None;
    }
    let f = analysis::power_law_fit(&x, &y, None, analysis::ErrorScale::ReducedChi2).ok()?;
    let (a, _) = f.get("A")?;
    let (b, e) = f.get("beta")?;
    Some((b, if f.dof > 0 { e } else { f64::NAN }, a))
}

/// One exponent of one model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Exponent {
    /// Value (finest grid with a fit).
    pub value: f64,
    /// 1σ from the fit.
    pub fit_error: f64,
    /// Largest difference to the other grids (NaN with one).
    pub grid_spread: f64,
    /// sqrt(fit² + spread²) (NaN parts count as 0 unless both are NaN).
    pub error: f64,
    /// Grid of the value.
    pub n: u32,
    /// Rungs fitted.
    pub points: usize,
    /// Prefactor A of A |l|^e.
    pub prefactor: f64,
}

impl Exponent {
    /// No fit on any grid.
    pub const NONE: Exponent = Exponent {
        value: f64::NAN,
        fit_error: f64::NAN,
        grid_spread: f64::NAN,
        error: f64::NAN,
        n: 0,
        points: 0,
        prefactor: f64::NAN,
    };
}

fn nan0(v: f64) -> f64 {
    if v.is_nan() { 0.0 } else { v }
}

/// Combines per-grid fits (ascending n) as the module docs say.
pub fn combine(per_grid: &[(u32, Option<ExponentFit>)]) -> Exponent {
    let Some((n, fin)) = per_grid
        .iter()
        .rev()
        .find_map(|(n, f)| f.as_ref().map(|f| (*n, f)))
    else {
        return Exponent::NONE;
    };
    let others: Vec<f64> = per_grid
        .iter()
        .filter(|(m, f)| *m != n && f.is_some())
        .map(|(_, f)| f.as_ref().expect("some").value)
        .collect();
    let spread = others
        .iter()
        .map(|v| (v - fin.value).abs())
        .fold(f64::NAN, f64::max);
    let error = if fin.error.is_nan() && spread.is_nan() {
        f64::NAN
    } else {
        nan0(fin.error).hypot(nan0(spread))
    };
    Exponent {
        value: fin.value,
        fit_error: fin.error,
        grid_spread: spread,
        error,
        n,
        points: fin.points,
        prefactor: fin.prefactor,
    }
}

/// The exponents of one model as read back.
#[derive(Clone, Debug)]
pub struct ModelExponents {
    /// Model name.
    pub lattice: String,
    /// The window fits, in [`NAMES`] order.
    pub exponents: [Exponent; 4],
    /// The asymptotic estimates from the combined (uniform + refined) ladder, in [`NAMES`]
    /// order (β from the flux; [`asymptotic::estimate_combined`]).
    pub asymptotic: [Asymptotic; 4],
    /// The same from the uniform ladder alone (the estimate before the refined ladder fed it).
    pub uniform_asymptotic: [Asymptotic; 4],
    /// Which ladder each asymptotic estimate used (`uniform`, `uniform+refined below …`).
    pub asymptotic_method: [String; 4],
    /// 3ζ + υ − χ of the uniform-only asymptotic estimates.
    pub beta_identity_uniform: Asymptotic,
    /// 3ζ + υ − χ of the asymptotic estimates.
    pub beta_identity_asymptotic: Asymptotic,
    /// The asymptotic estimates from the neck lengths, in [`NECK_ROWS`] order.
    pub neck_asymptotic: [Asymptotic; 2],
    /// Which ladders and measure each of them used (`neck_width_rms: refined from |l| = …`).
    pub neck_method: [String; 2],
    /// 3ζ + υ − χ of the asymptotic ζ, υ from the neck's rms width and χ from below.
    pub beta_identity_neck: Asymptotic,
    /// ζ with L_c free (finest grid) and its fit error.
    pub zeta_lc_free: (f64, f64),
    /// 3ζ + υ − χ and its error.
    pub beta_identity: (f64, f64),
    /// Curvature ratio of the saddle.
    pub eta: f64,
    /// Per-grid measurements (ascending n).
    pub levels: Vec<LevelMeasure>,
}

impl ModelExponents {
    /// An exponent by name.
    pub fn get(&self, name: &str) -> Exponent {
        NAMES
            .iter()
            .position(|n| *n == name)
            .map_or(Exponent::NONE, |k| self.exponents[k])
    }
}

/// The identity 3ζ + υ − χ with its error (quadrature).
pub fn identity(z: &Exponent, u: &Exponent, c: &Exponent) -> (f64, f64) {
    (
        3.0 * z.value + u.value - c.value,
        (9.0 * z.error * z.error + u.error * u.error + c.error * c.error).sqrt(),
    )
}

/// The `exponents` kind's parameters.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExponentsParams {
    /// Square-root onset: fit the loaded nodes within span · r_c of the contact line.
    pub span: f64,
    /// Square-root onset: but at least this many nodes.
    pub min_nodes: usize,
}

impl TypedKind for ExponentsKind {
    type Params = ExponentsParams;
    /// Lower bound 0: fits over the ladders' per-rung numbers (kB), no grid-sized allocation.
    fn memory_estimate(
        &self,
        _params: &orchestrator::Params,
        _inputs: &std::collections::BTreeMap<String, Vec<orchestrator::Params>>,
    ) -> Option<u64> {
        Some(0)
    }
    fn name(&self) -> &str {
        "exponents"
    }
    fn code_version(&self) -> u64 {
        CODE_VERSION
    }
    fn doc(&self) -> &str {
        "near-critical exponents ζ, υ, χ, β per model from `ladder` stages, with fit and grid-spread error bars; asymptotic estimates over the chain of refined ladders (υ and χ from below also from their neck lengths) with a verdict; the identity β = 3ζ + υ − χ"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            ParamSpec::new("span", ParamType::float_range(0.05, 5.0))
                .default(0.5)
                .doc(
                    "square-root onset: fit the loaded nodes within span · r_c of the contact line",
                ),
            ParamSpec::new("min_nodes", ParamType::int_range(3, 50))
                .default(3)
                .doc("square-root onset: but at least this many nodes"),
        ]
    }
    fn inputs(&self, _params: &ExponentsParams) -> Vec<InputSpec> {
        vec![
            InputSpec::many("ladder", &["ladder"]).doc("one `ladder` stage per model"),
            InputSpec::many("refined", &["refined_ladder"])
                .optional()
                .doc("at most one `refined_ladder` stage per model (optional): extends the asymptotic fits of ζ, υ, χ, β below the uniform grids' reach; its neck lengths give υ and χ from below"),
            InputSpec::many("deep", &["refined_ladder"])
                .optional()
                .doc("at most one deeper `refined_ladder` stage per model (optional; the pipeline's `refined_deep_*`): chained below the `refined` one, ordered by depth (finest spacing)"),
            InputSpec::many("window", &["refined_window"])
                .optional()
                .doc("window checks (optional; the pipeline's `refined_deep_window_*`): each folds its window change into the grid error and flags of the ladder it checks, its neck pairs too (kinds::refined_window, kinds::refined_neck)"),
        ]
    }
    fn cost(&self, _params: &ExponentsParams) -> f64 {
        0.05
    }
    fn run(
        &self,
        ctx: &mut StageContext,
        params: &ExponentsParams,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        let opts = EdgeOptions {
            span: params.span,
            min_nodes: params.min_nodes,
        };
        let mut models = Vec::new();
        let mut flux_points = Vec::new();
        let mut heads = Vec::new();
        let mut summary = serde_json::Map::new();
        let linked = crate::neck_truncation::read_flagged(inputs)?;
        // each refined ladder's neck lengths (None: its artefact has none), in `refined` order
        let mut necks: Vec<Option<LinkedNeck>> = Vec::with_capacity(linked.len());
        for (l, r) in &linked {
            match refined_neck::read_linked(l, r, inputs.all("window"))? {
                Ok(n) => {
                    if let Some(note) = &n.note {
                        ctx.warn(note.clone());
                    }
                    necks.push(Some(n));
                }
                Err(note) => {
                    ctx.warn(format!(
                        "{note}: left out of the asymptotic υ and χ from the neck"
                    ));
                    necks.push(None);
                }
            }
        }
        let refined: Vec<Linked> = linked.into_iter().map(|(l, _)| l).collect();
        for r in inputs.all("ladder") {
            let d = LadderData::read(r)?;
            let name = d.lattice.name();
            if models.contains(&name) {
                bail!("two `ladder` inputs for the {name} model; give one per model");
            }
            models.push(name);
            let chain = chain_of(&refined, d.lattice);
            // the chain's neck ladders, in chain order
            let neck_ladders: Vec<_> = chain
                .iter()
                .map(|c| {
                    let i = refined
                        .iter()
                        .position(|x| std::ptr::eq(x, *c))
                        .expect("the chain's links are in `refined`");
                    necks[i].as_ref().map(LinkedNeck::ladder)
                })
                .collect();
            let neck_chain: Vec<_> = chain
                .iter()
                .zip(&neck_ladders)
                .map(|(c, n)| (c.depth, n.as_ref()))
                .collect();
            let stats = model::run_model(
                ctx,
                out,
                &d,
                (&chain, &neck_chain),
                &opts,
                &mut heads,
                &mut flux_points,
            )?;
            summary.insert(name.to_string(), stats);
        }
        if models.is_empty() {
            bail!("`exponents` needs at least one `ladder` input");
        }
        out.set_attr("models", json!(models))?;
        crate::headline::write(out, &heads)?;
        if let Some((b, e, a)) = pooled_beta(&flux_points) {
            out.set_attr("beta", b)?;
            if e.is_finite() {
                out.set_attr("beta_err", e)?;
            }
            out.set_attr("beta_prefactor", a)?;
            summary.insert("beta_pooled".into(), json!([b, e]));
        }
        Ok(StageReport::with_stats(serde_json::Value::Object(summary)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pooled_beta_fits_the_window_only() {
        // slope 3.45 inside the window, 2.0 below it (a pre-asymptotic or unresolved tail)
        let law = |d: f64| {
            if d >= WINDOW.0 {
                2.0 * d.powf(3.45)
            } else {
                2.0 * WINDOW.0.powf(3.45) * (d / WINDOW.0).powf(2.0)
            }
        };
        let d = [5e-2, 2e-2, 1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4];
        let pts = vec![(d.to_vec(), d.iter().map(|&x| law(x)).collect::<Vec<f64>>())];
        let (b, _, a) = pooled_beta(&pts).unwrap();
        // an exact power law over the window's four points: rounding only
        assert!((b - 3.45).abs() < 1e-9, "{b}");
        assert!((a - 2.0).abs() < 1e-6, "{a}");
        let outside = vec![(vec![1e-3, 5e-4], vec![1.0, 0.5])];
        assert!(pooled_beta(&outside).is_none());
    }

    fn fit(v: f64, e: f64) -> Option<ExponentFit> {
        Some(ExponentFit {
            value: v,
            error: e,
            prefactor: 1.0,
            points: 4,
        })
    }

    #[test]
    fn the_finest_grid_gives_the_value_and_the_others_the_spread() {
        let e = combine(&[
            (8, fit(1.25, 0.01)),
            (9, fit(1.22, 0.002)),
            (10, fit(1.21, 0.003)),
        ]);
        assert_eq!((e.value, e.n), (1.21, 10));
        assert!((e.grid_spread - 0.04).abs() < 1e-12);
        assert!((e.error - 0.003f64.hypot(0.04)).abs() < 1e-12);
        // a grid without a fit is skipped; one grid: no spread
        let e = combine(&[(8, fit(1.25, 0.01)), (9, None)]);
        assert_eq!(e.n, 8);
        assert!(e.grid_spread.is_nan() && e.error == 0.01);
        assert!(combine(&[(8, None)]).value.is_nan());
    }

    #[test]
    fn identity_of_the_conjectured_exponents_is_69_20() {
        let ex = |v: f64| Exponent {
            value: v,
            error: 0.01,
            ..Exponent::NONE
        };
        let (b, e) = identity(&ex(1.2), &ex(0.45), &ex(0.6));
        assert!((b - CONJECTURED[3].0).abs() < 1e-12);
        assert!((e - (11.0f64).sqrt() * 0.01).abs() < 1e-12);
    }
}
