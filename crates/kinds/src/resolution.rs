//! `resolution`: one model's `critical` levels extrapolated to zero grid spacing
//! (`critical::Extrapolated`: `v0 + c h^p`, error = fit ⊕ leave-one-out spread), and the scenes
//! built from three of them: the convergence figures and the comparison table with the paper.
//!
//! # Parameters
//! `area_order` (order of the leading error of contact areas, default 1: the perimeter),
//! `load_order` (`"free"`, the default: fitted, falling back to `critical::FALLBACK_ORDER` when
//! convergence is not monotone; or a number).
//!
//! # Inputs
//! `levels`: `critical` stages of one model (each with one or more grids); together at least two
//! distinct n, none twice.
//!
//! # Artefact
//! - `n`, `h` (λ): one entry per level, ascending n ([`LevelRow`]);
//! - one group per quantity (`l_c`, `l_c_x`, `l_c_y`, `a_p_raw[_x|_y]`, `a_p_corrected[_x|_y]`,
//!   `p_fc_over_l_c`, `l_c_subgrid`): datasets `v`, `sem`, `h` ([`ResolvedPoint`]; `l_c_subgrid`
//!   uses only the levels with a sub-grid fit); attributes `ok`, `v0`, `v0_error`,
//!   `v0_fit_error`, `v0_subset_spread` (NaN without), `order`, `order_error`, `c`, `c_error`,
//!   `cov_v0_c`, `note`, `error`;
//! - root attributes `lattice`, `p_fc_exact`, `shift_rule`, the headline values `l_c`,
//!   `a_p_raw`, `a_p_corrected` with `_error`, `p_fc_over_l_c` = p_fc_exact / L_c with
//!   `_error`, the finest level's `l_c_subgrid`, `zeta` (with errors), and the paper's values
//!   `paper_a_p`, `paper_a_p_error`, `paper_p_fc_over_l_c` (NaN where the paper gives none);
//! - headline numbers ([`crate::headline`]): "a_p <model> (corrected)", "a_p <model> (raw)",
//!   "L_c <model>", "p_fc/L_c <model>" with the paper's values where it gives them.

use crate::critical::CriticalLevel;
use crate::headline::Headline;
use anyhow::{Result, bail};
use critical::{Extrapolated, Stat};
use formats::records::{Record, read_in};
use orchestrator::{
    InputSpec, Inputs, ParamIssue, ParamSpec, ParamType, Params, StageContext, StageReport,
    TypedKind,
};
use serde::Deserialize;
use serde_json::{Value, json};
use std::collections::BTreeMap;
use store::{ArtefactReader, ArtefactWriter};
use surface::Lattice;

/// The `resolution` stage kind.
pub struct ResolutionKind;

/// Bump when the artefact's content changes for the same inputs.
pub const CODE_VERSION: u64 = 2;

/// The paper's a_p (value, error) with the labels as corrected in PHYSICS.md.
pub fn paper_a_p(l: Lattice) -> (f64, f64) {
    match l {
        Lattice::Hexagonal => (0.17826, 0.00011),
        Lattice::Square => (0.40185, 0.00006),
        Lattice::Triangular => (0.67323, 0.00001),
    }
}

/// The paper's p_fc/L_c ("≈ 31" hexagonal, "1.4" triangular; none for the square model).
pub fn paper_ratio(l: Lattice) -> f64 {
    match l {
        Lattice::Hexagonal => 31.0,
        Lattice::Square => f64::NAN,
        Lattice::Triangular => 1.4,
    }
}

/// An extrapolation order: `"free"` or a number > 0.
fn parse_order(key: &str, v: &Value) -> Result<analysis::Order> {
    if let Some(s) = v.as_str() {
        if s == "free" {
            return Ok(analysis::Order::Free);
        }
        bail!("parameter `{key}` = {s:?}: allowed \"free\" or a number > 0");
    }
    match v.as_f64() {
        Some(p) if p.is_finite() && p > 0.0 => Ok(analysis::Order::Fixed(p)),
        _ => bail!("parameter `{key}` = {v}: allowed \"free\" or a number > 0"),
    }
}

const AREA_QUANTITIES: [&str; 6] = [
    "a_p_raw",
    "a_p_raw_x",
    "a_p_raw_y",
    "a_p_corrected",
    "a_p_corrected_x",
    "a_p_corrected_y",
];
const LOAD_QUANTITIES: [&str; 4] = ["l_c", "l_c_x", "l_c_y", "p_fc_over_l_c"];

/// The `resolution` kind's parameters.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResolutionParams {
    /// Order of the leading error term of contact areas.
    pub area_order: f64,
    /// Order for loads: `"free"` or a number; kept as written so that `check` reports a bad
    /// value at its key (see [`ResolutionParams::load_order`]).
    pub load_order: Value,
}

impl ResolutionParams {
    /// The load order.
    pub fn load_order(&self) -> Result<analysis::Order> {
        parse_order("load_order", &self.load_order)
    }
}

impl TypedKind for ResolutionKind {
    type Params = ResolutionParams;
    /// Lower bound 0: fits over per-level numbers (bytes), no grid-sized allocation.
    fn memory_estimate(
        &self,
        _params: &orchestrator::Params,
        _inputs: &std::collections::BTreeMap<String, Vec<orchestrator::Params>>,
    ) -> Option<u64> {
        Some(0)
    }
    fn name(&self) -> &str {
        "resolution"
    }
    fn code_version(&self) -> u64 {
        CODE_VERSION
    }
    fn doc(&self) -> &str {
        "extrapolates a model's critical levels (L_c, a_p) to zero grid spacing"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            ParamSpec::new("area_order", ParamType::positive())
                .default(1.0)
                .doc("order of the leading error term of contact areas (1: the perimeter)"),
            ParamSpec::new("load_order", ParamType::Any)
                .default("free")
                .doc("order for loads: \"free\" (fitted) or a number"),
        ]
    }
    fn check(&self, params: &ResolutionParams) -> Result<(), ParamIssue> {
        params
            .load_order()
            .map(|_| ())
            .map_err(|e| ParamIssue::new("load_order", e.to_string()))
    }
    fn check_inputs(
        &self,
        _params: &Params,
        inputs: &BTreeMap<String, Vec<Params>>,
    ) -> Result<(), String> {
        let levels = inputs.get("levels").map(Vec::as_slice).unwrap_or(&[]);
        let models: std::collections::BTreeSet<&str> = levels
            .iter()
            .filter_map(|p| p.str("lattice").ok())
            .collect();
        if models.len() > 1 {
            return Err(format!(
                "its `levels` mix models ({}); give the critical stages of one model",
                models.into_iter().collect::<Vec<_>>().join(", ")
            ));
        }
        let mut all: Vec<u32> = Vec::new();
        for p in levels {
            all.extend(crate::critical::ns(p).map_err(|e| e.to_string())?);
        }
        all.sort_unstable();
        let n_all = all.len();
        all.dedup();
        if all.len() != n_all {
            return Err(format!(
                "its `levels` give a grid twice (n = {all:?} with repeats); give each n once"
            ));
        }
        if all.len() < 2 {
            return Err(format!(
                "its `levels` give {} grid(s) in total (n = {all:?}); at least two distinct n are needed to extrapolate (e.g. `critical_ns` with two or more entries)",
                all.len()
            ));
        }
        Ok(())
    }
    fn inputs(&self, _params: &ResolutionParams) -> Vec<InputSpec> {
        vec![
            InputSpec::many("levels", &["critical"])
                .doc("the model's critical stages (their grids together)"),
        ]
    }
    fn cost(&self, _params: &ResolutionParams) -> f64 {
        0.01
    }
    fn run(
        &self,
        ctx: &mut StageContext,
        params: &ResolutionParams,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        let area_order = analysis::Order::Fixed(params.area_order);
        let mut load_order = params.load_order()?;
        let levels = input_levels(ctx, inputs)?;
        if load_order == analysis::Order::Free && levels.len() < 4 {
            // a fitted order needs ≥ 4 levels for a degree of freedom and leave-one-out refits
            load_order = analysis::Order::Fixed(critical::FALLBACK_ORDER);
            ctx.warn(format!(
                "{} levels: too few to fit the order of L_c's convergence; fixed order {} used",
                levels.len(),
                critical::FALLBACK_ORDER
            ));
        }
        let h: Vec<f64> = levels.iter().map(|l| l.h).collect();
        let rows: Vec<LevelRow> = levels.iter().map(|l| LevelRow { n: l.n, h: l.h }).collect();
        LevelRow::write(&rows, out, "")?;
        let ex = extrapolate(&levels, &h, load_order, area_order);
        for e in &ex {
            write_extrapolation(out, e)?;
            if let Some(n) = &e.note {
                ctx.warn(format!("{}: {n}", e.name));
            }
            if let Err(m) = &e.fit {
                ctx.warn(format!("{}: extrapolation failed: {m}", e.name));
            }
        }
        let [(l_c, l_c_e), (a_r, a_r_e), (a_c, a_c_e)] = write_summary(out, &levels, &ex)?;
        Ok(StageReport::with_stats(json!({
            "levels": levels.len(),
            "l_c": [l_c, l_c_e],
            "a_p_raw": [a_r, a_r_e],
            "a_p_corrected": [a_c, a_c_e],
        })))
    }
}

/// The `levels` inputs' levels, ascending n, checked: one model, distinct grids, at least two.
fn input_levels(ctx: &mut StageContext, inputs: &Inputs) -> Result<Vec<CriticalLevel>> {
    let mut levels: Vec<CriticalLevel> = Vec::new();
    for r in inputs.all("levels") {
        levels.extend(CriticalLevel::read_all(r)?);
    }
    levels.sort_by_key(|l| l.n);
    let lattice = levels[0].lattice;
    if let Some(l) = levels.iter().find(|l| l.lattice != lattice) {
        bail!(
            "the levels mix models: {} and {}",
            lattice.name(),
            l.lattice.name()
        );
    }
    if levels.windows(2).any(|w| w[0].n == w[1].n) {
        bail!("two levels have the same n; give one critical stage per grid");
    }
    if levels.len() < 2 {
        bail!(
            "at least two levels (grids) are needed to extrapolate; got {}",
            levels.len()
        );
    }
    if levels.iter().any(|l| l.shift_rule != levels[0].shift_rule) {
        ctx.warn("the levels use different shift rules: their averages are not one family");
    }
    Ok(levels)
}

/// Extrapolates every quantity to h → 0 (and the sub-grid L_c where ≥ 2 levels have one).
fn extrapolate(
    levels: &[CriticalLevel],
    h: &[f64],
    load_order: analysis::Order,
    area_order: analysis::Order,
) -> Vec<Extrapolated> {
    let stat = |l: &CriticalLevel, q: &str| {
        let (mean, sem) = l.get(q).unwrap_or((f64::NAN, f64::NAN));
        Stat {
            mean,
            std: f64::NAN,
            sem,
            count: 0,
        }
    };
    let mut ex: Vec<Extrapolated> = Vec::new();
    for q in LOAD_QUANTITIES {
        let s: Vec<Stat> = levels.iter().map(|l| stat(l, q)).collect();
        ex.push(Extrapolated::new(q, h, &s, load_order));
    }
    for q in AREA_QUANTITIES {
        let s: Vec<Stat> = levels.iter().map(|l| stat(l, q)).collect();
        ex.push(Extrapolated::new(q, h, &s, area_order));
    }
    let sub: Vec<&CriticalLevel> = levels
        .iter()
        .filter(|l| l.l_c_subgrid.0.is_finite())
        .collect();
    if sub.len() >= 2 {
        let hs: Vec<f64> = sub.iter().map(|l| l.h).collect();
        let s: Vec<Stat> = sub
            .iter()
            .map(|l| Stat {
                mean: l.l_c_subgrid.0,
                std: f64::NAN,
                sem: 0.0,
                count: 1,
            })
            .collect();
        ex.push(Extrapolated::new("l_c_subgrid", &hs, &s, load_order));
    }
    ex
}

/// Root attributes and headlines; returns (value, error) of L_c, raw a_p, corrected a_p.
fn write_summary(
    out: &mut ArtefactWriter,
    levels: &[CriticalLevel],
    ex: &[Extrapolated],
) -> Result<[(f64, f64); 3]> {
    let lattice = levels[0].lattice;
    let value = |q: &str| {
        ex.iter()
            .find(|e| e.name == q)
            .and_then(|e| e.value())
            .unwrap_or((f64::NAN, f64::NAN))
    };
    let p_fc = lattice.exact().p_fc;
    let (l_c, l_c_e) = value("l_c");
    let (a_r, a_r_e) = value("a_p_raw");
    let (a_c, a_c_e) = value("a_p_corrected");
    out.set_attr("lattice", lattice.name())?;
    out.set_attr("shift_rule", levels[0].shift_rule as i64)?;
    out.set_attr("p_fc_exact", p_fc)?;
    out.set_attr("l_c", l_c)?;
    out.set_attr("l_c_error", l_c_e)?;
    out.set_attr("a_p_raw", a_r)?;
    out.set_attr("a_p_raw_error", a_r_e)?;
    out.set_attr("a_p_corrected", a_c)?;
    out.set_attr("a_p_corrected_error", a_c_e)?;
    out.set_attr("p_fc_over_l_c", p_fc / l_c)?;
    out.set_attr("p_fc_over_l_c_error", p_fc / l_c * l_c_e / l_c)?;
    let finest = levels.last().expect("levels");
    out.set_attr("finest_n", finest.n as i64)?;
    out.set_attr("l_c_subgrid", finest.l_c_subgrid.0)?;
    out.set_attr("l_c_subgrid_error", finest.l_c_subgrid.1)?;
    out.set_attr("zeta", finest.zeta.0)?;
    out.set_attr("zeta_error", finest.zeta.1)?;
    let (pa, pe) = paper_a_p(lattice);
    out.set_attr("paper_a_p", pa)?;
    out.set_attr("paper_a_p_error", pe)?;
    out.set_attr("paper_p_fc_over_l_c", paper_ratio(lattice))?;
    let m = lattice.name();
    let (ratio, ratio_e) = (p_fc / l_c, p_fc / l_c * l_c_e / l_c);
    crate::headline::write(
        out,
        &[
            Headline::new(format!("a_p {m} (corrected)"), a_c, a_c_e).paper(pa, pe),
            Headline::new(format!("a_p {m} (raw)"), a_r, a_r_e).paper(pa, pe),
            Headline::new(format!("L_c {m}"), l_c, l_c_e),
            Headline::new(format!("p_fc/L_c {m}"), ratio, ratio_e)
                .paper(paper_ratio(lattice), f64::NAN),
        ],
    )?;
    Ok([(l_c, l_c_e), (a_r, a_r_e), (a_c, a_c_e)])
}

fn write_extrapolation(out: &mut ArtefactWriter, e: &Extrapolated) -> Result<()> {
    let g = e.name.as_str();
    let points: Vec<ResolvedPoint> = (e.v.iter().zip(&e.sem).zip(&e.h))
        .map(|((&v, &sem), &h)| ResolvedPoint { v, sem, h })
        .collect();
    ResolvedPoint::write(&points, out, g)?;
    out.set_attr_at(g, "note", e.note.clone().unwrap_or_default())?;
    match &e.fit {
        Ok(f) => {
            let cov = |a: &str, b: &str| {
                let i = f.fit.names.iter().position(|n| *n == a);
                let j = f.fit.names.iter().position(|n| *n == b);
                match (i, j) {
                    (Some(i), Some(j)) => f.fit.covariance[i][j],
                    _ => f64::NAN,
                }
            };
            out.set_attr_at(g, "ok", true)?;
            out.set_attr_at(g, "v0", f.v0)?;
            out.set_attr_at(g, "v0_error", f.v0_error)?;
            out.set_attr_at(g, "v0_fit_error", f.v0_fit_error)?;
            out.set_attr_at(
                g,
                "v0_subset_spread",
                f.v0_subset_spread.unwrap_or(f64::NAN),
            )?;
            out.set_attr_at(g, "order", f.order)?;
            out.set_attr_at(g, "order_error", f.order_error)?;
            out.set_attr_at(g, "c", f.c)?;
            out.set_attr_at(g, "c_error", f.c_error)?;
            out.set_attr_at(g, "cov_v0_c", cov("v0", "c"))?;
            out.set_attr_at(g, "error", "")?;
        }
        Err(m) => {
            out.set_attr_at(g, "ok", false)?;
            for k in [
                "v0",
                "v0_error",
                "v0_fit_error",
                "v0_subset_spread",
                "order",
            ] {
                out.set_attr_at(g, k, f64::NAN)?;
            }
            for k in ["order_error", "c", "c_error", "cov_v0_c"] {
                out.set_attr_at(g, k, f64::NAN)?;
            }
            out.set_attr_at(g, "error", m.as_str())?;
        }
    }
    Ok(())
}

formats::record! {
    /// One level of a `resolution` artefact (the root datasets `n`, `h`), ascending n.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct LevelRow {
        /// Grid exponent.
        pub n: u32,
        /// Grid spacing √(Δx Δy) (λ).
        pub h: f64,
    }
}

/// The levels of a `resolution` artefact, ascending n.
pub fn read_levels(r: &ArtefactReader) -> Result<Vec<LevelRow>> {
    read_in(r, "")
}

formats::record! {
    /// One level's value of a quantity (`<quantity>/*`), coarse to fine.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct ResolvedPoint {
        /// Value on the level.
        pub v: f64,
        /// Its standard error over shifts.
        pub sem: f64,
        /// Grid spacing (λ).
        pub h: f64,
    }
}

/// One quantity of a `resolution` artefact.
#[derive(Clone, Debug)]
pub struct ResolvedQuantity {
    /// The levels' values, coarse to fine (descending h).
    pub points: Vec<ResolvedPoint>,
    /// Extrapolated value, error, order, c, c error and cov(v0, c) (NaN when the fit failed).
    pub v0: f64,
    /// 1σ of v0 (fit ⊕ subset spread).
    pub v0_error: f64,
    /// Order p.
    pub order: f64,
    /// Coefficient c.
    pub c: f64,
    /// 1σ of c.
    pub c_error: f64,
    /// Covariance of v0 and c from the fit.
    pub cov_v0_c: f64,
    /// 1σ of v0 from the fit alone.
    pub v0_fit_error: f64,
}

impl ResolvedQuantity {
    /// Reads quantity `q` of a `resolution` artefact.
    pub fn read(r: &ArtefactReader, q: &str) -> Result<Self> {
        let a = |k: &str| r.attr_f64_at(q, k);
        Ok(ResolvedQuantity {
            points: read_in(r, q)?,
            v0: a("v0")?,
            v0_error: a("v0_error")?,
            order: a("order")?,
            c: a("c")?,
            c_error: a("c_error")?,
            cov_v0_c: a("cov_v0_c")?,
            v0_fit_error: a("v0_fit_error")?,
        })
    }

    /// The fit `v0 + c h^p` at spacing `x` and its 1σ band: the fit covariance of (v0, c) with
    /// the total error of v0 in place of its fit part.
    pub fn curve(&self, x: f64) -> (f64, f64) {
        let xp = x.powf(self.order);
        let y = self.v0 + self.c * xp;
        let cov = if self.cov_v0_c.is_finite() {
            self.cov_v0_c
        } else {
            0.0
        };
        let c_e = if self.c_error.is_finite() {
            self.c_error
        } else {
            0.0
        };
        let var = self.v0_error.powi(2) + (xp * c_e).powi(2) + 2.0 * xp * cov;
        (y, var.max(0.0).sqrt())
    }
}

/// The summary of a `resolution` artefact: its root attributes (value, 1σ; NaN where an
/// attribute is missing, −1 for a missing integer) and its levels.
#[derive(Clone, Debug)]
pub struct ResolutionSummary {
    /// Model.
    pub lattice: Lattice,
    /// The levels (`None` if they cannot be read).
    pub levels: Option<Vec<LevelRow>>,
    /// m of the m × m shifts per grid.
    pub shift_rule: i64,
    /// Finest grid exponent.
    pub finest_n: i64,
    /// Exact continuum full-contact pressure.
    pub p_fc_exact: f64,
    /// Extrapolated L_c.
    pub l_c: (f64, f64),
    /// Extrapolated raw a_p.
    pub a_p_raw: (f64, f64),
    /// Extrapolated perimeter-corrected a_p.
    pub a_p_corrected: (f64, f64),
    /// p_fc_exact / L_c.
    pub p_fc_over_l_c: (f64, f64),
    /// The finest grid's sub-grid L_c.
    pub l_c_subgrid: (f64, f64),
    /// The finest grid's ζ.
    pub zeta: (f64, f64),
    /// The paper's a_p.
    pub paper_a_p: (f64, f64),
    /// The paper's p_fc/L_c (NaN where it gives none).
    pub paper_p_fc_over_l_c: f64,
}

impl ResolutionSummary {
    /// Reads the summary of a `resolution` artefact (an error only without a known `lattice`).
    pub fn read(r: &ArtefactReader) -> Result<Self> {
        let f = |k: &str| r.attr_f64(k).unwrap_or(f64::NAN);
        let pair = |k: &str| (f(k), f(&format!("{k}_error")));
        Ok(ResolutionSummary {
            lattice: crate::surface::lattice_from_name(&r.attr_str("lattice")?)?,
            levels: read_levels(r).ok(),
            shift_rule: r.attr_i64("shift_rule").unwrap_or(-1),
            finest_n: r.attr_i64("finest_n").unwrap_or(-1),
            p_fc_exact: f("p_fc_exact"),
            l_c: pair("l_c"),
            a_p_raw: pair("a_p_raw"),
            a_p_corrected: pair("a_p_corrected"),
            p_fc_over_l_c: pair("p_fc_over_l_c"),
            l_c_subgrid: pair("l_c_subgrid"),
            zeta: pair("zeta"),
            paper_a_p: pair("paper_a_p"),
            paper_p_fc_over_l_c: f("paper_p_fc_over_l_c"),
        })
    }
}

/// The three models' `resolution` artefacts, by input name, in the paper's order.
pub const MODEL_INPUTS: [(&str, Lattice); 3] = [
    ("hexagonal", Lattice::Hexagonal),
    ("square", Lattice::Square),
    ("triangular", Lattice::Triangular),
];
