//! `refined_ladder`: the saddle gap, the open channel's half-width, the blocked channel's
//! half-length and the flux of one model at reduced loads down to |l| = 1e-5 on locally refined
//! discretisations (`critical::refined`: a window of `window` base cells around the axis saddle
//! refined 2^k times, the rest of the periodic cell on the base grid), and their running
//! exponents ζ_eff, υ_eff, β_eff (l < 0) and χ_eff (l > 0) with grid errors. This is where the
//! near-critical ladder goes below the uniform grids' reach (docs/near-critical.md).
//!
//! # What is computed
//! For every k of `levels` (ascending) a discretisation D(k) = (model, base 2^`base`, k,
//! `window`, `margin`): its own p_c(D) (the load at which D's saddle node closes; a safeguarded
//! secant to 1e-11 relative, the first from the periodic base grid's closing load, each next
//! from the previous D's), then the ladder at p_c(D)(1 + l) for every l of `ls` (< 0),
//! warm-started. With `margin_check` > 0 the finest D once more with that margin (the
//! far-field interpolation error, which at |l| ~ 1e-5 is the largest one). On every rung the
//! saddle gap (ζ, l < 0) and, on the fine window around the saddle
//! (`Refinement::saddle_window`), the open half-width r_c (υ, l < 0, square-root onset) or the
//! blocked half-length a (χ, l > 0, Hertz fit), as on the uniform ladders' windows; and below
//! p_c(D) the flux (β, `critical::refined_flow`): for the square model the cell's conductivity
//! K along the channel by the single-window series replacement, for the triangular and
//! hexagonal models the refined saddle's own two-terminal conductance (its flow window between
//! isobaric end lines; a single refined window makes the cell's coarse saddles close early, so
//! the cell's K is wrong there, while the critical neck's conductance has the exponent β). The
//! running
//! exponents (`critical::refined::running_exponent`): between neighbouring rungs of the finest D
//! that measure the quantity, the grid error the larger of the change from the next coarser D
//! and from the margin check, flagged above 0.005, when unknown, when a rung's window is too
//! small or its solve did not converge, or when the window's contact set did not change between
//! the two rungs. Fit errors: ζ from the solver tolerance (`tol_gap`, the 1σ of a node value,
//! relative to g_s); υ, χ from the edge fits' 1σ (0 for a fit without a degree of freedom); β
//! from the solver tolerance propagated to the flux (σ_K/K = 3 tol_gap/g_s, K ∝ g_s^(β/ζ)).
//!
//! # Parameters
//! `lattice`, `base` (base grid exponent), `levels` (ascending k, 1..=6; two or more give the
//! level error), `window` (base cells), `margin` (base cells of exact near field around the
//! window), `margin_check` (0: none: grid error = level change alone), `ls` (reduced loads ≠ 0; > 0 give χ only), `tol_gap` (h0; the composite
//! solve stagnates near p_c below ~1e-13 at k = 3, 1e-12 at k = 4, 5e-12 at k = 5), `max_iter`.
//!
//! # Artefact
//! Root attributes `lattice`, `base`, `window`, `spacing` (finest fine spacing, λ), `p_fc`
//! (the base grid's p_fc), `tol_gap`, `flux_method` (`series` or `saddle_window`); per discretisation `d/<i>` (coarse to fine, then the margin check)
//! attributes `levels`, `margin`, `p_c`, `p_c_lo`, `p_c_hi`, `probes`, `spacing`, `wall_s`,
//! `iterations`, `flux_wall_s` (the flow solves' share of `wall_s`) and datasets ([`RefinedRungRow`]) `l`, `load`, `saddle_gap`, `contact_area`,
//! `iterations`, `wall_s`, `neck_nodes`, `flagged`, `half_width`, `half_width_error`,
//! `half_length`, `half_length_error`, `conductance`, `conductance_error` (NaN where not
//! measured) plus `flag` (strings, empty if none), `edge_note` (why an edge fit failed, empty if
//! none) and `flux_note` (why the flux was not measured, empty if it was); the running exponents
//! `running/*` (ζ), `running_upsilon/*`, `running_chi/*` and `running_beta/*`
//! ([`RefinedPairRow`]: `l_hi`,
//! `l_lo`, `value`, `error_levels`, `error_margin`, `grid_error`, `fit_error`) and their
//! `flag`s; the finest discretisation's axis-gap profiles `profile/*` ([`RefinedProfileRow`]:
//! `l`, `distance` (λ from the saddle along the channel axis), `gap` (h0), every rung, from the
//! fine window around the saddle; read by [`read_profiles`]).

use crate::surface::lattice_spec;
use analysis::ScalingPoint;
use anyhow::{Result, anyhow};
use critical::refined::{
    ClosingLoad, Discretisation, LadderPair, Measured, RefinedOptions, RefinedRung, Refinement,
    base_guess, running_exponent,
};
use critical::refined_flow::{FluxMethod, ladder_with_flux};
use formats::records::{Record, read_in};
use orchestrator::{
    InputSpec, Inputs, ParamIssue, ParamSpec, ParamType, StageContext, StageReport, TypedKind,
};
use serde::Deserialize;
use serde_json::json;
use store::{ArtefactReader, ArtefactWriter};
use surface::Lattice;

/// The `refined_ladder` stage kind.
pub struct RefinedLadderKind;

/// Bump when the artefact's content changes for the same parameters.
pub const CODE_VERSION: u64 = 6;

/// The running exponents' grid-error bound (issue 13's 0.005), for the uniform, refined and deep
/// ladders alike (`exponents::asymptotic` re-exports it).
pub const GRID_BOUND: f64 = 0.005;

/// Lower bound of a refined stage's memory: the base grid's fields and one real field on the
/// box of the blockwise operator ((window + 2 margin + 2) 2^k fine nodes per side). Shared by
/// `refined_ladder` and `refined_window`.
pub(crate) fn box_memory(base: i64, window: i64, margin: i64, k: i64) -> u64 {
    let side = ((window + 2 * margin + 2) as u64) << k.clamp(0, 6);
    4 * crate::surface::field_bytes(base) + 8 * side * side
}

/// The `levels` parameter of the refined kinds (refinement levels, strictly ascending).
pub(crate) fn levels_spec(doc: &str) -> ParamSpec {
    ParamSpec::new(
        "levels",
        ParamType::Array {
            elem: Box::new(ParamType::int_range(1, 6)),
            min_len: 1,
            max_len: Some(6),
        },
    )
    .doc(doc)
}

/// The `ls` parameter of the refined kinds (reduced loads; its default and doc are the kind's).
pub(crate) fn ls_spec() -> ParamSpec {
    ParamSpec::new(
        "ls",
        ParamType::Array {
            elem: Box::new(ParamType::float_range(-0.5, 0.5)),
            min_len: 2,
            max_len: Some(64),
        },
    )
}

/// The `max_iter` parameter of the refined kinds.
pub(crate) fn max_iter_spec() -> ParamSpec {
    ParamSpec::new("max_iter", ParamType::int_range(10, 1_000_000))
        .default(2000)
        .doc("iteration cap per solve attempt")
}

/// `levels` strictly ascending.
pub(crate) fn check_levels(levels: &[u32]) -> Result<(), ParamIssue> {
    if levels.windows(2).any(|w| w[1] <= w[0]) {
        return Err(ParamIssue::new(
            "levels",
            format!("{levels:?}: allowed a strictly ascending list of refinement levels"),
        ));
    }
    Ok(())
}

/// `ls` distinct and none at p_c itself.
pub(crate) fn check_ls(ls: &[f64]) -> Result<(), ParamIssue> {
    if let Some(l) = ls.iter().find(|l| l.abs() < 1e-12) {
        return Err(ParamIssue::new(
            "ls",
            format!("{l}: allowed reduced loads with |l| ≥ 1e-12 (p_c itself measures nothing)"),
        ));
    }
    crate::ladder::check_distinct_ls(ls)
}

/// The `refined_ladder` kind's parameters.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RefinedLadderParams {
    /// Which model.
    #[serde(deserialize_with = "crate::solver::from_str")]
    pub lattice: Lattice,
    /// Base grid exponent.
    pub base: u32,
    /// Refinement levels k, strictly ascending.
    pub levels: Vec<u32>,
    /// Window side (base cells).
    pub window: u32,
    /// Exact near field around the window (base cells).
    pub margin: u32,
    /// A second margin for the finest level (0: none).
    pub margin_check: u32,
    /// Reduced loads, ≠ 0 (> 0: χ only).
    pub ls: Vec<f64>,
    /// Composite Polonsky–Keer tolerance (h0).
    pub tol_gap: f64,
    /// Iteration cap per solve attempt.
    pub max_iter: u32,
}

impl TypedKind for RefinedLadderKind {
    type Params = RefinedLadderParams;
    /// Lower bound: the base grid's fields and, on the finest level, one real field on the
    /// box of the blockwise operator ((window + 2 margin + 2) 2^k fine nodes per side; its
    /// transforms work on twice that).
    fn memory_estimate(
        &self,
        params: &orchestrator::Params,
        _inputs: &std::collections::BTreeMap<String, Vec<orchestrator::Params>>,
    ) -> Option<u64> {
        let base = params.i64("base").ok()?;
        let k = params
            .get("levels")
            .ok()?
            .as_array()?
            .iter()
            .filter_map(|v| v.as_i64())
            .max()?;
        let margin = params
            .i64("margin")
            .ok()?
            .max(params.i64("margin_check").unwrap_or(0));
        Some(box_memory(base, params.i64("window").ok()?, margin, k))
    }
    fn name(&self) -> &str {
        "refined_ladder"
    }
    fn code_version(&self) -> u64 {
        CODE_VERSION
    }
    fn doc(&self) -> &str {
        "the saddle gap, channel width and length and flux at reduced loads down to 1e-5 on locally refined discretisations (one window around the axis saddle refined 2^k times), each from its own p_c, and the running ζ, υ, χ, β with level and margin errors"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            lattice_spec(),
            ParamSpec::new("base", ParamType::int_range(4, 11))
                .doc("base grid exponent: 2^base × 2^base periodic nodes"),
            levels_spec("refinement levels k (fine spacing = base spacing / 2^k), strictly ascending; the finest gives the values, the next its level error"),
            ParamSpec::new("window", ParamType::int_range(2, 512))
                .default(16)
                .doc("side of the refined window around the axis saddle (base cells)"),
            ParamSpec::new("margin", ParamType::int_range(5, 64))
                .default(12)
                .doc("near field computed exactly around the window (base cells; at least ORDER/2 + 1 = 5, and window + 2 margin + 2 ≤ 2^base); the far field beyond is interpolated"),
            ParamSpec::new("margin_check", ParamType::int_range(0, 64))
                .default(0)
                .doc("a second margin for the finest level, whose change is part of the grid error (0: none: the grid error is then the level change alone)"),
            ls_spec()
            .default(json!(critical::refined::default_ls()))
            .doc("reduced loads (L − L_c)/L_c ≠ 0, distinct: those < 0 give ζ and υ, those > 0 χ"),
            crate::solver::tol_gap_spec(),
            max_iter_spec(),
        ]
    }
    fn check(&self, params: &RefinedLadderParams) -> Result<(), ParamIssue> {
        check_levels(&params.levels)?;
        if params.margin_check != 0 && params.margin_check < 5 {
            return Err(ParamIssue::new(
                "margin_check",
                format!(
                    "{}: allowed 0 (none) or 5 ..= 64 (the far-field interpolation needs ORDER/2 + 1 cells)",
                    params.margin_check
                ),
            ));
        }
        if params.margin_check == params.margin {
            return Err(ParamIssue::new(
                "margin_check",
                format!(
                    "{}: equal to `margin`; allowed 0 (none) or another margin",
                    params.margin_check
                ),
            ));
        }
        check_ls(&params.ls)
    }
    fn inputs(&self, _params: &RefinedLadderParams) -> Vec<InputSpec> {
        Vec::new()
    }
    fn cost(&self, params: &RefinedLadderParams) -> f64 {
        // a k = 3 ladder on a 256² base is ~2 min: weight by the box of the blockwise operator
        let k = params.levels.iter().copied().max().unwrap_or(1) as i32;
        let n = params.levels.len() as f64 + f64::from(u8::from(params.margin_check > 0));
        n * 4f64.powi(k - 3) * 4f64.powi(params.base as i32 - 8).max(1.0) * 100.0
    }
    fn run(
        &self,
        ctx: &mut StageContext,
        params: &RefinedLadderParams,
        _inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        let opts = RefinedOptions {
            tol_gap: params.tol_gap,
            max_iter: params.max_iter as usize,
            ..Default::default()
        };
        let d = Discretisation {
            lattice: params.lattice,
            base_log2: params.base,
            levels: params.levels[0],
            window: params.window as usize,
            margin: params.margin as usize,
        };
        // the first guess: the periodic base grid's closing load of the same saddle
        let (base, p_fc) = base_guess(d, &opts)?;
        let mut plan: Vec<Discretisation> =
            params.levels.iter().map(|&k| d.with_levels(k)).collect();
        let finest = *plan.last().expect("levels has one entry at least");
        if params.margin_check > 0 {
            plan.push(finest.with_margin(params.margin_check as usize));
        }
        let (mut guess, mut width) = (base.p_c(), 2e-4);
        let method = FluxMethod::of(params.lattice);
        let mut runs = Vec::new();
        let mut flux_walls = Vec::new();
        for (i, &disc) in plan.iter().enumerate() {
            ctx.progress(
                i as f64 / plan.len() as f64,
                &format!("k = {}, margin {}: p_c", disc.levels, disc.margin),
            );
            let t = std::time::Instant::now();
            let mut r = Refinement::new(disc, &opts)?;
            let c = r.critical_load(Some(guess), width)?;
            // the finest level's axis-gap profiles (`profile/*`), from each rung's saddle window
            let keep = i + 1 == params.levels.len();
            let mut profiles = Vec::new();
            let (rungs, fluxes) =
                ladder_with_flux(&mut r, c.p_c(), &params.ls, method, &mut |rung, _, w| {
                    if keep {
                        profiles.extend(profile_rows(rung.l, w));
                    }
                })?;
            let wall = t.elapsed().as_secs_f64();
            write_discretisation(out, &format!("d/{i}"), disc, &c, &rungs, wall, r.iterations)?;
            if keep {
                RefinedProfileRow::write(&profiles, out, "profile")?;
            }
            let notes: Vec<String> = fluxes
                .iter()
                .map(|f| f.as_ref().err().cloned().unwrap_or_default())
                .collect();
            out.write_strings(&format!("d/{i}/flux_note"), &notes)?;
            let flux_wall: f64 = fluxes.iter().flatten().map(|f| f.wall_s).sum();
            out.set_attr_at(&format!("d/{i}"), "flux_wall_s", flux_wall)?;
            flux_walls.push(flux_wall);
            // the next discretisation's p_c lies within ~6e-7 of this one's (critical::refined,
            // "The p_c search"; a miss costs the search one probe or two)
            (guess, width) = (c.p_c(), 2e-6);
            runs.push((disc, c, rungs));
        }
        let fine = &runs[params.levels.len() - 1].2;
        let coarser = (params.levels.len() > 1).then(|| &runs[params.levels.len() - 2].2[..]);
        let margin = (params.margin_check > 0).then(|| &runs[runs.len() - 1].2[..]);
        let mut npairs = 0;
        let mut flagged = 0;
        for m in Measured::ALL {
            let pairs = running_exponent(m, fine, coarser, margin, GRID_BOUND, opts.tol_gap);
            let rows: Vec<RefinedPairRow> = pairs
                .iter()
                .map(|z| RefinedPairRow {
                    l_hi: z.l_hi,
                    l_lo: z.l_lo,
                    value: z.value,
                    error_levels: z.error_levels,
                    error_margin: z.error_margin,
                    grid_error: z.grid_error,
                    fit_error: z.fit_error,
                })
                .collect();
            let at = running_group(m);
            RefinedPairRow::write(&rows, out, at)?;
            let flags: Vec<String> = pairs
                .iter()
                .map(|z| z.flag.as_ref().map_or(String::new(), |f| f.to_string()))
                .collect();
            out.write_strings(&format!("{at}/flag"), &flags)?;
            npairs += pairs.len();
            flagged += flags.iter().filter(|f| !f.is_empty()).count();
        }
        let (lx, ly) = params.lattice.cell();
        out.set_cell(lx, ly)?;
        out.set_attr("lattice", params.lattice.name())?;
        out.set_attr("base", params.base as i64)?;
        out.set_attr("window", params.window as i64)?;
        out.set_attr("spacing", finest.spacing())?;
        out.set_attr("p_fc", p_fc)?;
        out.set_attr("tol_gap", params.tol_gap)?;
        out.set_attr("flux_method", method.name())?;
        ctx.progress(1.0, "written");
        Ok(StageReport::with_stats(json!({
            "p_c_over_p_fc": runs.iter().map(|r| r.1.p_c() / p_fc).collect::<Vec<_>>(),
            "pairs": npairs,
            "flagged_pairs": flagged,
            "flux_wall_s": flux_walls,
        })))
    }
}

/// One rung's axis-gap profile ([`RefinedProfileRow`]): the gap on the channel axis of the fine
/// window around the saddle `w` (`Refinement::saddle_window`, `critical::scaling::axis_gap`),
/// from the saddle outward.
fn profile_rows(l: f64, w: &critical::ladder::Window) -> impl Iterator<Item = RefinedProfileRow> {
    let (dist, gap) = critical::scaling::axis_gap(w);
    dist.into_iter()
        .zip(gap)
        .map(move |(distance, gap)| RefinedProfileRow { l, distance, gap })
}

/// The artefact group of a measured quantity's running exponents (`running` for ζ, as before υ,
/// χ and β were measured).
pub fn running_group(m: Measured) -> &'static str {
    match m {
        Measured::SaddleGap => "running",
        Measured::OpenHalfWidth => "running_upsilon",
        Measured::BlockedHalfLength => "running_chi",
        Measured::Flux => "running_beta",
    }
}

/// A rung as the refined kinds store it.
pub fn rung_row(r: &RefinedRung) -> RefinedRungRow {
    RefinedRungRow {
        l: r.l,
        load: r.load,
        saddle_gap: r.saddle_gap,
        contact_area: r.contact_area,
        iterations: r.iterations,
        wall_s: r.wall_s,
        neck_nodes: r.neck_nodes,
        flagged: r.flag.is_some(),
        half_width: r.half_width.0,
        half_width_error: r.half_width.1,
        half_length: r.half_length.0,
        half_length_error: r.half_length.1,
        conductance: r.flux.0,
        conductance_error: r.flux.1,
    }
}

/// Rungs as `<at>/*` ([`RefinedRungRow`]) with their flags as `<at>/flag` (empty: unflagged)
/// and the neck lengths from the gap field ([`critical::refined::NeckRecord`], λ, NaN where
/// not measured) as `<at>/neck_width_rms`, `<at>/neck_width_level`, `<at>/neck_rise_length`
/// (datasets beside the record, so that artefacts written before them still read as
/// [`RefinedRungRow`]s; not yet used by any table); shared by `refined_ladder` (each `d/<i>`)
/// and `refined_window` (`rungs`).
pub fn write_rungs(out: &mut ArtefactWriter, at: &str, rungs: &[RefinedRung]) -> Result<()> {
    let rows: Vec<RefinedRungRow> = rungs.iter().map(rung_row).collect();
    RefinedRungRow::write(&rows, out, at)?;
    type Pick = fn(&critical::refined::NeckRecord) -> f64;
    let columns: [(&str, Pick); 3] = [
        ("neck_width_rms", |n| n.width_rms),
        ("neck_width_level", |n| n.width_level),
        ("neck_rise_length", |n| n.rise_length),
    ];
    for (name, pick) in columns {
        let v: Vec<f64> = rungs.iter().map(|r| pick(&r.neck)).collect();
        out.write_f64_1d(&format!("{at}/{name}"), &v)?;
    }
    let flags: Vec<String> = rungs
        .iter()
        .map(|r| r.flag.as_ref().map_or(String::new(), |f| f.to_string()))
        .collect();
    out.write_strings(&format!("{at}/flag"), &flags)?;
    Ok(())
}

/// One discretisation's p_c and rungs (`<at>/*`).
fn write_discretisation(
    out: &mut ArtefactWriter,
    at: &str,
    d: Discretisation,
    c: &ClosingLoad,
    rungs: &[RefinedRung],
    wall: f64,
    iterations: usize,
) -> Result<()> {
    write_rungs(out, at, rungs)?;
    let notes: Vec<String> = rungs
        .iter()
        .map(|r| r.edge_note.clone().unwrap_or_default())
        .collect();
    out.write_strings(&format!("{at}/edge_note"), &notes)?;
    out.set_attr_at(at, "levels", d.levels as i64)?;
    out.set_attr_at(at, "margin", d.margin as i64)?;
    out.set_attr_at(at, "p_c", c.p_c())?;
    out.set_attr_at(at, "p_c_lo", c.lo)?;
    out.set_attr_at(at, "p_c_hi", c.hi)?;
    out.set_attr_at(at, "probes", c.probes as i64)?;
    out.set_attr_at(at, "spacing", d.spacing())?;
    out.set_attr_at(at, "wall_s", wall)?;
    out.set_attr_at(at, "iterations", iterations as i64)?;
    Ok(())
}

formats::record! {
    /// One rung of one refined discretisation (`d/<i>/*`, ascending l).
    #[derive(Clone, Debug, PartialEq)]
    pub struct RefinedRungRow {
        /// Reduced load from the discretisation's own p_c.
        pub l: f64,
        /// Load (E* h0/λ).
        pub load: f64,
        /// Gap at the saddle's fine node (h0).
        pub saddle_gap: f64,
        /// Contact area fraction.
        pub contact_area: f64,
        /// Solver iterations.
        pub iterations: usize,
        /// Wall time (s).
        pub wall_s: f64,
        /// Open fine nodes across the channel through the saddle.
        pub neck_nodes: usize,
        /// The rung is flagged (`flag` says why).
        pub flagged: bool,
        /// l < 0: open half-width r_c (λ), NaN if not measured.
        pub half_width: f64,
        /// Its fit's 1σ.
        pub half_width_error: f64,
        /// l > 0: blocked half-length a (λ), NaN if not measured.
        pub half_length: f64,
        /// Its fit's 1σ.
        pub half_length_error: f64,
        /// l < 0: the flux's conductance (`critical::refined_flow`), NaN if not measured.
        pub conductance: f64,
        /// Its 1σ (the solver tolerance propagated).
        pub conductance_error: f64,
    }
}

formats::record! {
    /// One point of the finest discretisation's axis-gap profiles (`profile/*`, optional: absent
    /// before CODE_VERSION 6): rungs in the ladder's order, each from the saddle outward.
    #[derive(Clone, Debug, PartialEq)]
    pub struct RefinedProfileRow {
        /// The rung's reduced load.
        pub l: f64,
        /// Distance from the saddle along the channel axis (λ).
        pub distance: f64,
        /// Gap (h0).
        pub gap: f64,
    }
}

formats::record! {
    /// One running-exponent pair of the finest discretisation (`running/*` for ζ,
    /// `running_upsilon/*`, `running_chi/*`).
    #[derive(Clone, Debug, PartialEq)]
    pub struct RefinedPairRow {
        /// The rung farther from p_c (signed).
        pub l_hi: f64,
        /// The rung nearer p_c (signed).
        pub l_lo: f64,
        /// ζ_eff, υ_eff, χ_eff or β_eff.
        pub value: f64,
        /// |change from the next coarser level| (NaN if unknown).
        pub error_levels: f64,
        /// |change from the margin check| (NaN if unknown).
        pub error_margin: f64,
        /// The larger of the two (NaN if either is unknown).
        pub grid_error: f64,
        /// ζ, β: from the solver tolerance; υ, χ: from the edge fits.
        pub fit_error: f64,
    }
}

/// One discretisation as read back.
#[derive(Clone, Debug)]
pub struct RefinedLevel {
    /// Refinement levels k.
    pub levels: u32,
    /// Margin (base cells).
    pub margin: u32,
    /// p_c(D) (E* h0/λ).
    pub p_c: f64,
    /// Fine spacing (λ).
    pub spacing: f64,
    /// The rungs and their flags.
    pub rungs: Vec<(RefinedRungRow, String)>,
}

/// A `refined_ladder` artefact as read back.
#[derive(Clone, Debug)]
pub struct RefinedData {
    /// Model.
    pub lattice: Lattice,
    /// The base grid's p_fc (E* h0/λ).
    pub p_fc: f64,
    /// Window (base cells).
    pub window: u32,
    /// The finest fine spacing (λ).
    pub spacing: f64,
    /// The composite solver tolerance (h0): the 1σ of a saddle gap.
    pub tol_gap: f64,
    /// Discretisations, as computed (coarse to fine, then the margin check).
    pub levels: Vec<RefinedLevel>,
    /// What the flux measures (`series` or `saddle_window`, `critical::refined_flow`).
    pub flux_method: String,
    /// Running exponents of the finest discretisation (ζ, υ, χ, then β) with their flags.
    pub running: Vec<RefinedPair>,
}

/// One rung's axis-gap profile of the finest discretisation as read back: (l, distance from
/// the saddle along the channel axis (λ), gap (h0)).
pub type RefinedProfile = (f64, Vec<f64>, Vec<f64>);

/// The finest discretisation's axis-gap profiles (`profile/*`), one per rung in the ladder's
/// (ascending l) order; empty for an artefact written before they were stored (CODE_VERSION < 6).
pub fn read_profiles(r: &ArtefactReader) -> Result<Vec<RefinedProfile>> {
    if !r.has_dataset("profile/l") {
        return Ok(Vec::new());
    }
    let rows: Vec<RefinedProfileRow> = read_in(r, "profile")?;
    let mut out: Vec<RefinedProfile> = Vec::new();
    for row in rows {
        match out.last_mut() {
            Some(p) if p.0 == row.l => {
                p.1.push(row.distance);
                p.2.push(row.gap);
            }
            _ => out.push((row.l, vec![row.distance], vec![row.gap])),
        }
    }
    Ok(out)
}

/// One running-exponent pair as read back.
#[derive(Clone, Debug)]
pub struct RefinedPair {
    /// What it measures (ζ, υ, χ, β).
    pub exponent: Measured,
    /// The pair.
    pub row: RefinedPairRow,
    /// Why it must not be used silently (empty: usable).
    pub flag: String,
}

impl RefinedData {
    /// Reads a `refined_ladder` artefact.
    pub fn read(r: &ArtefactReader) -> Result<Self> {
        let lattice = crate::surface::lattice_from_name(&r.attr_str("lattice")?)?;
        let mut names = r.members("d")?;
        names.sort_by_key(|n| n.parse::<usize>().unwrap_or(usize::MAX));
        let mut levels = Vec::new();
        for name in names {
            let at = format!("d/{name}");
            let rows: Vec<RefinedRungRow> = read_in(r, &at)?;
            let flags = r.read_strings(&format!("{at}/flag"))?;
            if flags.len() != rows.len() {
                return Err(anyhow!(
                    "{}: {at}: {} flags for {} rungs",
                    r.path().display(),
                    flags.len(),
                    rows.len()
                ));
            }
            levels.push(RefinedLevel {
                levels: r.attr_i64_at(&at, "levels")? as u32,
                margin: r.attr_i64_at(&at, "margin")? as u32,
                p_c: r.attr_f64_at(&at, "p_c")?,
                spacing: r.attr_f64_at(&at, "spacing")?,
                rungs: rows.into_iter().zip(flags).collect(),
            });
        }
        let mut running = Vec::new();
        for m in Measured::ALL {
            let at = running_group(m);
            let pairs: Vec<RefinedPairRow> = read_in(r, at)?;
            let flags = r.read_strings(&format!("{at}/flag"))?;
            if flags.len() != pairs.len() {
                return Err(anyhow!(
                    "{}: {at}: {} flags for {} pairs",
                    r.path().display(),
                    flags.len(),
                    pairs.len()
                ));
            }
            running.extend(pairs.into_iter().zip(flags).map(|(row, flag)| RefinedPair {
                exponent: m,
                row,
                flag,
            }));
        }
        Ok(RefinedData {
            lattice,
            p_fc: r.attr_f64("p_fc")?,
            window: r.attr_i64("window")? as u32,
            spacing: r.attr_f64("spacing")?,
            tol_gap: r.attr_f64("tol_gap")?,
            flux_method: r.attr_str("flux_method")?,
            levels,
            running,
        })
    }

    /// The finest discretisation (the one whose rungs give the running exponents: the first
    /// with the most levels; the margin check comes after it).
    pub fn finest(&self) -> Option<&RefinedLevel> {
        let k = self.levels.iter().map(|l| l.levels).max()?;
        self.levels.iter().find(|l| l.levels == k)
    }

    /// The finest discretisation's measurements of `m` as scaling points (ζ: saddle gap, 1σ
    /// `tol_gap`; υ, χ: the edge fits, 1σ theirs, 0 if NaN; β: the conductance, 1σ its own; rungs without a measurement left
    /// out, as `critical::refined::Measured::point`).
    pub fn points(&self, m: Measured) -> Vec<ScalingPoint> {
        let Some(f) = self.finest() else {
            return Vec::new();
        };
        f.rungs
            .iter()
            .filter_map(|(r, _)| {
                let (y, s) = match m {
                    Measured::SaddleGap if r.l < 0.0 => (r.saddle_gap, self.tol_gap),
                    Measured::OpenHalfWidth if r.l < 0.0 => (r.half_width, r.half_width_error),
                    Measured::BlockedHalfLength if r.l > 0.0 => {
                        (r.half_length, r.half_length_error)
                    }
                    Measured::Flux if r.l < 0.0 => (r.conductance, r.conductance_error),
                    _ => return None,
                };
                (y.is_finite() && y > 0.0)
                    .then(|| ScalingPoint::new(r.l, y, if s.is_finite() { s } else { 0.0 }))
            })
            .collect()
    }

    /// The running pairs of `m` as `critical::refined::combined_ladder` takes them.
    pub fn pairs(&self, m: Measured) -> Vec<LadderPair> {
        self.running
            .iter()
            .filter(|p| p.exponent == m)
            .map(|p| LadderPair {
                l_hi: p.row.l_hi,
                l_lo: p.row.l_lo,
                usable: p.flag.is_empty() && p.row.value.is_finite(),
            })
            .collect()
    }
}
