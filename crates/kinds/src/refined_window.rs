//! `refined_window`: the window term of a refined ladder's grid error (issue 13). The stage
//! solves the checked ladder's discretisation D = (model, base 2^`base`, k = `level`,
//! `window`, `margin`) once more with the window widened to `window_check` base cells, at ONE
//! level, over the same reduced loads (each D from its own p_c), and stores that D's rungs and
//! running exponents. The stages that read refined ladders (`exponents`, scenes `running`,
//! `refined`, and through `exponents` Figures 5 and 6; [`crate::refined_chain::read_linked`],
//! input `window`) then take, per running pair of the checked ladder,
//! **Δw = (running exponent at (k, window_check)) − (running exponent at (k, window))** and fold
//! it into the pair's grid error with the rule the level and margin changes already follow
//! ([`fold`]: the larger of the changes, unknown if one is unknown), flagging a pair whose
//! |Δw| exceeds the bound (0.005) or whose Δw is unknown (`window change …`), so that the
//! combined ladder and the asymptotic fits leave it out exactly as they leave out a pair with a
//! level flag.
//!
//! # What it measures, and why a separate stage
//! The contact lines outside the refined window are the base grid's, in D(k − 1), D(k) and
//! D(k, other margin) alike: neither the level change nor the margin change sees them
//! (docs/near-critical.md, "Zoom discretisations on a 1024² base": square, 1024², k = 3, window 16 passes the rung-level window check
//! from −2e-4 on and has level and margin changes ≤ 3.8e-3, yet its 1e-4→5e-5 ζ_eff is 5.4e-3
//! off window 32's). The rung-level window check of `critical::refined` (a rung is flagged when
//! the neck's structure reaches the window's edge: fewer than 4 contact-line crossings or a run
//! narrower than 2 base cells) looks at one solution's edge; it cannot say how much the base
//! grid's contact lines outside the window move the exponent. Δw measures that effect directly,
//! and both are needed: the edge check catches a window that cuts the neck itself (there Δw may
//! even be small by accident: two wrong windows can agree), Δw a window that contains the neck
//! but not enough of the contact lines that shape it. The stage is separate from
//! `refined_ladder` so that those stages keep their cache and their kind's code identity.
//!
//! # The level assumption
//! The window error comes from the base grid outside the window, which every level shares, so
//! Δw is measured at one level (`level`; 0: the coarser of the checked ladder's two finest
//! levels, the cheaper one) and applied to the pairs of the checked ladder's finest level.
//! This is an assumption, not a theorem: a finer level resolves the neck inside the window
//! better, which can change how strongly the outside matters. On a tiny grid it does not hold
//! (square, 64² base, margin 5, window 8 → 16, pairs 2e-2→1e-2 … 2e-3→1e-3: Δw = +2.5e-3,
//! −6.1e-4, +1.4e-3, +1.3e-3 at k = 1 against −2.2e-4, −5.4e-4, −7.7e-3, +4.1e-4 at k = 2;
//! window 12 → 24: ≤ 1.7e-3 at both levels; `tests/refined_window.rs`), so a Δw measured at
//! the coarser level bounds the finest level's window error only as far as the two levels'
//! window errors agree, which the pipeline does not measure (a second check at the finest
//! level, `level` = the finest, would; it costs about as much as the deep ladder's finest D).
//!
//! # Cost
//! One discretisation: a p_c search from the periodic base grid's closing load, then the
//! ladder with its flux (as one D of `refined_ladder`, with a box of (window_check + 2 margin +
//! 2) 2^k fine nodes per side). Paper preset, square (1024², k = 3, window 64, margin 12, six
//! loads): 357 CPU-s, 10 min 37 s wall at load 7–9, 564 MB; Δw(32 → 64) of ζ_eff ≤ 5.3e-4, of
//! β_eff ≤ 1.5e-3 (docs/pipeline.md).
//!
//! # Parameters
//! `lattice`, `base`, `levels` (the checked ladder's, ascending), `level` (0: the coarser of
//! the two finest of `levels`, or the only one), `window` (the checked ladder's), `window_check`
//! (> `window`), `margin`, `ls`, `tol_gap`, `max_iter`: the checked ladder's values but for
//! `window_check` and `level`.
//!
//! # Artefact
//! Root attributes `lattice`, `base`, `level`, `window` (the checked window), `window_check`,
//! `margin`, `p_c`, `p_c_lo`, `p_c_hi`, `probes`, `p_fc`, `spacing` (the check's fine spacing),
//! `tol_gap`, `flux_method`, `wall_s`, `iterations`; `rungs/*` ([`RefinedRungRow`]) with
//! `rungs/flag`; per exponent (`zeta`, `upsilon`, `chi`, `beta`) `pairs_<exponent>/*`
//! ([`WindowPairRow`]: `l_hi`, `l_lo`, `value`) with `flag` (the pair's own flag: a flagged
//! rung, or a window contact set unchanged between the two rungs; empty if usable).

pub use crate::refined_ladder::rung_row;
use crate::refined_ladder::{
    GRID_BOUND, RefinedData, RefinedPair, RefinedRungRow, box_memory, check_levels, check_ls,
    levels_spec, ls_spec, max_iter_spec, write_rungs,
};
use crate::surface::lattice_spec;
use analysis::same_load;
use anyhow::{Result, anyhow};
use critical::refined::{
    Discretisation, Measured, PairFlag, RefinedOptions, RefinedRung, Refinement, base_guess,
    running_exponent,
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

/// The `refined_window` stage kind.
pub struct RefinedWindowKind;

/// Bump when the artefact's content changes for the same parameters.
pub const CODE_VERSION: u64 = 1;

/// The `refined_window` kind's parameters.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RefinedWindowParams {
    /// Which model.
    #[serde(deserialize_with = "crate::solver::from_str")]
    pub lattice: Lattice,
    /// Base grid exponent (the checked ladder's).
    pub base: u32,
    /// The checked ladder's refinement levels, strictly ascending.
    pub levels: Vec<u32>,
    /// The level of the check (0: the coarser of the two finest of `levels`).
    pub level: u32,
    /// The checked ladder's window (base cells).
    pub window: u32,
    /// The check's window (base cells), larger than `window`.
    pub window_check: u32,
    /// Exact near field around the window (base cells; the checked ladder's).
    pub margin: u32,
    /// Reduced loads (the checked ladder's).
    pub ls: Vec<f64>,
    /// Composite Polonsky–Keer tolerance (h0).
    pub tol_gap: f64,
    /// Iteration cap per solve attempt.
    pub max_iter: u32,
}

impl RefinedWindowParams {
    /// The level of the check: `level`, or (0) the coarser of the two finest of `levels`
    /// (the only one if there is one).
    pub fn check_level(&self) -> u32 {
        if self.level > 0 {
            return self.level;
        }
        let n = self.levels.len();
        self.levels[n.saturating_sub(2)]
    }

    /// The check's discretisation: the checked ladder's at [`Self::check_level`] with the
    /// window `window_check`.
    pub fn discretisation(&self) -> Discretisation {
        Discretisation {
            lattice: self.lattice,
            base_log2: self.base,
            levels: self.check_level(),
            window: self.window as usize,
            margin: self.margin as usize,
        }
        .with_window(self.window_check as usize)
    }
}

impl TypedKind for RefinedWindowKind {
    type Params = RefinedWindowParams;
    /// Lower bound: the base grid's fields and one real field on the box of the blockwise
    /// operator ((window_check + 2 margin + 2) 2^k fine nodes per side), as `refined_ladder`.
    fn memory_estimate(
        &self,
        params: &orchestrator::Params,
        _inputs: &std::collections::BTreeMap<String, Vec<orchestrator::Params>>,
    ) -> Option<u64> {
        let base = params.i64("base").ok()?;
        let levels: Vec<i64> = params
            .get("levels")
            .ok()?
            .as_array()?
            .iter()
            .filter_map(|v| v.as_i64())
            .collect();
        let level = match params.i64("level").unwrap_or(0) {
            0 => *levels.get(levels.len().saturating_sub(2))?,
            k => k,
        };
        Some(box_memory(
            base,
            params.i64("window_check").ok()?,
            params.i64("margin").ok()?,
            level,
        ))
    }
    fn name(&self) -> &str {
        "refined_window"
    }
    fn code_version(&self) -> u64 {
        CODE_VERSION
    }
    fn doc(&self) -> &str {
        "the window check of a refined ladder: the same discretisation at one level with a larger window, whose change of the running ζ, υ, χ, β enters the checked ladder's grid error in the stages that read it"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            lattice_spec(),
            ParamSpec::new("base", ParamType::int_range(4, 11))
                .doc("base grid exponent of the checked ladder"),
            levels_spec("the checked ladder's refinement levels k, strictly ascending"),
            ParamSpec::new("level", ParamType::int_range(0, 6))
                .default(0)
                .doc("the level k of the check, one of `levels` (0: the coarser of the two finest of `levels`, or the only one; the window error comes from the base grid outside the window, which every level shares)"),
            ParamSpec::new("window", ParamType::int_range(2, 512))
                .doc("the checked ladder's window (base cells)"),
            ParamSpec::new("window_check", ParamType::int_range(3, 512))
                .doc("the check's window (base cells), larger than `window`"),
            ParamSpec::new("margin", ParamType::int_range(5, 64))
                .default(12)
                .doc("the checked ladder's margin (base cells; window_check + 2 margin + 2 ≤ 2^base)"),
            ls_spec()
            .doc("the checked ladder's reduced loads (≠ 0, distinct), from the check's own p_c"),
            crate::solver::tol_gap_spec(),
            max_iter_spec(),
        ]
    }
    fn check(&self, params: &RefinedWindowParams) -> Result<(), ParamIssue> {
        check_levels(&params.levels)?;
        if params.level != 0 && !params.levels.contains(&params.level) {
            return Err(ParamIssue::new(
                "level",
                format!(
                    "{}: allowed 0 (the coarser of the two finest levels) or one of `levels` {:?} (the check is compared with the checked ladder at that level)",
                    params.level, params.levels
                ),
            ));
        }
        if params.window_check <= params.window {
            return Err(ParamIssue::new(
                "window_check",
                format!(
                    "{}: allowed a window larger than the checked ladder's `window` = {}",
                    params.window_check, params.window
                ),
            ));
        }
        let side = 1u64 << params.base;
        if u64::from(params.window_check + 2 * params.margin + 2) > side {
            return Err(ParamIssue::new(
                "window_check",
                format!(
                    "{}: window_check + 2 margin + 2 = {} exceeds the base grid's {side} cells; allowed ≤ {}",
                    params.window_check,
                    params.window_check + 2 * params.margin + 2,
                    side.saturating_sub(u64::from(2 * params.margin + 2))
                ),
            ));
        }
        check_ls(&params.ls)
    }
    fn inputs(&self, _params: &RefinedWindowParams) -> Vec<InputSpec> {
        Vec::new()
    }
    fn cost(&self, params: &RefinedWindowParams) -> f64 {
        // as refined_ladder (one D), weighted by the check's box over the checked window's
        let k = params.check_level() as i32;
        let wider = f64::from(params.window_check + 2 * params.margin + 2)
            / f64::from(params.window + 2 * params.margin + 2);
        4f64.powi(k - 3) * 4f64.powi(params.base as i32 - 8).max(1.0) * 100.0 * wider * wider
    }
    fn run(
        &self,
        ctx: &mut StageContext,
        params: &RefinedWindowParams,
        _inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        let opts = RefinedOptions {
            tol_gap: params.tol_gap,
            max_iter: params.max_iter as usize,
            ..Default::default()
        };
        let d = params.discretisation();
        ctx.progress(
            0.0,
            &format!("k = {}, window {}: periodic base guess", d.levels, d.window),
        );
        let t = std::time::Instant::now();
        let (base, p_fc) = base_guess(d, &opts)?;
        ctx.progress(0.1, &format!("k = {}, window {}: p_c", d.levels, d.window));
        let mut r = Refinement::new(d, &opts)?;
        let c = r.critical_load(Some(base.p_c()), 2e-4)?;
        ctx.progress(0.4, "ladder");
        let method = FluxMethod::of(params.lattice);
        let (rungs, _fluxes) =
            ladder_with_flux(&mut r, c.p_c(), &params.ls, method, &mut |_, _, _| {})?;
        let wall = t.elapsed().as_secs_f64();
        write_rungs(out, "rungs", &rungs)?;
        let mut npairs = 0;
        for m in Measured::ALL {
            let pairs = own_pairs(m, &rungs, opts.tol_gap);
            let rows: Vec<WindowPairRow> = pairs
                .iter()
                .map(|s| WindowPairRow {
                    l_hi: s.l_hi,
                    l_lo: s.l_lo,
                    value: s.value,
                })
                .collect();
            let at = pairs_group(m);
            WindowPairRow::write(&rows, out, &at)?;
            let flags: Vec<String> = pairs.iter().map(|s| s.flag.clone()).collect();
            out.write_strings(&format!("{at}/flag"), &flags)?;
            npairs += pairs.len();
        }
        let (lx, ly) = params.lattice.cell();
        out.set_cell(lx, ly)?;
        out.set_attr("lattice", params.lattice.name())?;
        out.set_attr("base", params.base as i64)?;
        out.set_attr("level", d.levels as i64)?;
        out.set_attr("window", params.window as i64)?;
        out.set_attr("window_check", params.window_check as i64)?;
        out.set_attr("margin", params.margin as i64)?;
        out.set_attr("p_c", c.p_c())?;
        out.set_attr("p_c_lo", c.lo)?;
        out.set_attr("p_c_hi", c.hi)?;
        out.set_attr("probes", c.probes as i64)?;
        out.set_attr("p_fc", p_fc)?;
        out.set_attr("spacing", d.spacing())?;
        out.set_attr("tol_gap", params.tol_gap)?;
        out.set_attr("flux_method", method.name())?;
        out.set_attr("wall_s", wall)?;
        out.set_attr("iterations", r.iterations as i64)?;
        ctx.progress(1.0, "written");
        Ok(StageReport::with_stats(json!({
            "p_c_over_p_fc": c.p_c() / p_fc,
            "pairs": npairs,
            "flagged_rungs": rungs.iter().filter(|r| r.flag.is_some()).count(),
        })))
    }
}

/// The artefact group of the check's running pairs of `m` (`pairs_zeta`, …).
fn pairs_group(m: Measured) -> String {
    format!("pairs_{}", m.name())
}

/// One running pair of one discretisation at one level: its loads, its value and its own
/// flag (a flagged rung, or the window's contact set unchanged; empty: usable).
#[derive(Clone, Debug, PartialEq)]
pub struct Slope {
    /// The rung farther from p_c (signed).
    pub l_hi: f64,
    /// The rung nearer p_c (signed).
    pub l_lo: f64,
    /// Δ ln y / Δ ln |l|.
    pub value: f64,
    /// Why it must not be compared (empty: usable).
    pub flag: String,
}

impl Slope {
    /// Whether it may be compared.
    pub fn usable(&self) -> bool {
        self.flag.is_empty() && self.value.is_finite()
    }
}

/// The running pairs of `m` on the check's own rungs with their own flags: those of
/// `critical::refined::running_exponent` without a comparison D (its "grid error unknown",
/// which only says that no comparison was given, is not the pair's own flag).
pub fn own_pairs(m: Measured, rungs: &[RefinedRung], sigma_gap: f64) -> Vec<Slope> {
    running_exponent(m, rungs, None, None, GRID_BOUND, sigma_gap)
        .into_iter()
        .map(|p| Slope {
            l_hi: p.l_hi,
            l_lo: p.l_lo,
            value: p.value,
            flag: match p.flag {
                None | Some(PairFlag::Unknown) => String::new(),
                Some(f) => f.to_string(),
            },
        })
        .collect()
}

/// The running pairs of `m` between neighbouring rungs of one stored discretisation (a
/// `refined_ladder` artefact's `d/<i>`), as `critical::refined` forms them: the rungs that
/// measure `m` (ζ: every rung below p_c(D); υ, χ, β: those with a finite positive value), by
/// descending |l|, value Δ ln y / Δ ln |l| with the same arithmetic. A pair is unusable if a
/// rung of it is flagged; the "contact set unchanged" flag needs the contact sets, which the
/// artefact does not keep, so it is not reproduced here (module docs).
pub fn level_slopes(rungs: &[(RefinedRungRow, String)], m: Measured) -> Vec<Slope> {
    let mut pts: Vec<(f64, f64, &str)> = rungs
        .iter()
        .filter_map(|(r, flag)| {
            // the σ do not enter a slope's value: the rung's own ones, the gap's unused
            m.select(
                r.l,
                (r.saddle_gap, 0.0),
                (r.half_width, r.half_width_error),
                (r.half_length, r.half_length_error),
                (r.conductance, r.conductance_error),
            )
            .map(|p| (r.l, p.y, flag.as_str()))
        })
        .collect();
    pts.sort_by(|a, b| b.0.abs().total_cmp(&a.0.abs()));
    pts.windows(2)
        .map(|w| {
            let ((la, ya, fa), (lb, yb, fb)) = (w[0], w[1]);
            let d = (la.abs() / lb.abs()).ln();
            let flag = [(la, fa), (lb, fb)]
                .iter()
                .find(|(_, f)| !f.is_empty())
                .map_or(String::new(), |(l, f)| format!("rung l = {l:e}: {f}"));
            Slope {
                l_hi: la,
                l_lo: lb,
                value: (ya / yb).ln() / d,
                flag,
            }
        })
        .collect()
}

/// Δw of the pair (l_hi, l_lo): the check's value minus the checked discretisation's at the
/// same loads ([`same_load`]); NaN (unknown) if either lacks that pair or has it flagged —
/// never 0 for a missing comparison.
pub fn window_change(checked: &[Slope], check: &[Slope], l_hi: f64, l_lo: f64) -> f64 {
    let find = |s: &[Slope]| {
        s.iter()
            .find(|p| same_load(p.l_hi, l_hi) && same_load(p.l_lo, l_lo))
            .filter(|p| p.usable())
            .map(|p| p.value)
    };
    match (find(check), find(checked)) {
        (Some(w), Some(v)) => w - v,
        _ => f64::NAN,
    }
}

/// Folds a pair's window change `dw` into its grid error and flag, by the rule of
/// `critical::refined::running_exponent` for the level and margin changes: the grid error is
/// the largest of the changes and unknown (NaN) if one is unknown; a pair not flagged already
/// is flagged when the window change is unknown or |dw| exceeds `bound` (an existing flag is
/// kept: it is the first reason, as there).
pub fn fold(grid_error: f64, flag: &str, dw: f64, bound: f64) -> (f64, String) {
    let grid = if grid_error.is_nan() || dw.is_nan() {
        f64::NAN
    } else {
        grid_error.max(dw.abs())
    };
    let flag = if !flag.is_empty() {
        flag.to_string()
    } else if dw.is_nan() {
        "window change unknown".to_string()
    } else if dw.abs() > bound {
        format!("window change {:.2e} > {bound:.2e}", dw.abs())
    } else {
        String::new()
    };
    (grid, flag)
}

formats::record! {
    /// One running pair of the window check's discretisation (`pairs_<exponent>/*`).
    #[derive(Clone, Debug, PartialEq)]
    pub struct WindowPairRow {
        /// The rung farther from p_c (signed).
        pub l_hi: f64,
        /// The rung nearer p_c (signed).
        pub l_lo: f64,
        /// ζ_eff, υ_eff, χ_eff or β_eff at (level, window_check).
        pub value: f64,
    }
}

/// A `refined_window` artefact as read back.
#[derive(Clone, Debug)]
pub struct WindowCheck {
    /// Model.
    pub lattice: Lattice,
    /// Base grid exponent.
    pub base: u32,
    /// The level k of the check.
    pub level: u32,
    /// The checked window (base cells).
    pub window: u32,
    /// The check's window (base cells).
    pub window_check: u32,
    /// Margin (base cells).
    pub margin: u32,
    /// The check's running pairs per exponent (ζ, υ, χ, β).
    pub pairs: Vec<(Measured, Vec<Slope>)>,
}

impl WindowCheck {
    /// Reads a `refined_window` artefact.
    pub fn read(r: &ArtefactReader) -> Result<Self> {
        let mut pairs = Vec::new();
        for m in Measured::ALL {
            let at = pairs_group(m);
            let rows: Vec<WindowPairRow> = read_in(r, &at)?;
            let flags = r.read_strings(&format!("{at}/flag"))?;
            if flags.len() != rows.len() {
                return Err(anyhow!(
                    "{}: {at}: {} flags for {} pairs",
                    r.path().display(),
                    flags.len(),
                    rows.len()
                ));
            }
            let slopes = rows
                .into_iter()
                .zip(flags)
                .map(|(p, flag)| Slope {
                    l_hi: p.l_hi,
                    l_lo: p.l_lo,
                    value: p.value,
                    flag,
                })
                .collect();
            pairs.push((m, slopes));
        }
        Ok(WindowCheck {
            lattice: crate::surface::lattice_from_name(&r.attr_str("lattice")?)?,
            base: r.attr_i64("base")? as u32,
            level: r.attr_i64("level")? as u32,
            window: r.attr_i64("window")? as u32,
            window_check: r.attr_i64("window_check")? as u32,
            margin: r.attr_i64("margin")? as u32,
            pairs,
        })
    }

    /// The check's pairs of `m`.
    pub fn of(&self, m: Measured) -> &[Slope] {
        self.pairs
            .iter()
            .find(|(x, _)| *x == m)
            .map_or(&[], |(_, s)| s.as_slice())
    }

    /// What it checks, for messages.
    pub fn describe(&self) -> String {
        format!(
            "{} window check (base 2^{}, k = {}, window {} → {}, margin {})",
            self.lattice.name(),
            self.base,
            self.level,
            self.window,
            self.window_check,
            self.margin
        )
    }

    /// Whether it checks the ladder `data` of base 2^`base`: same model, base and window, and
    /// the ladder has a discretisation at the check's level with its margin.
    pub fn checks(&self, data: &RefinedData, base: u32) -> bool {
        data.lattice == self.lattice
            && base == self.base
            && data.window == self.window
            && data
                .levels
                .iter()
                .any(|l| l.levels == self.level && l.margin == self.margin)
    }
}

/// Applies the window check to the ladder `data` (which [`WindowCheck::checks`]): Δw of every
/// running pair of its finest discretisation against its discretisation at the check's level
/// and margin (the level assumption: module docs), folded into the pair's grid error and flag
/// ([`fold`], bound [`GRID_BOUND`]). Returns Δw per pair of `data.running` (NaN: unknown).
pub fn apply(data: &mut RefinedData, check: &WindowCheck) -> Result<Vec<f64>> {
    let level = data
        .levels
        .iter()
        .find(|l| l.levels == check.level && l.margin == check.margin)
        .ok_or_else(|| {
            anyhow!(
                "{}: the {} ladder (window {}) has no discretisation at k = {} with margin {}",
                check.describe(),
                data.lattice.name(),
                data.window,
                check.level,
                check.margin
            )
        })?;
    let checked: Vec<(Measured, Vec<Slope>)> = Measured::ALL
        .iter()
        .map(|&m| (m, level_slopes(&level.rungs, m)))
        .collect();
    let of = |m: Measured| {
        checked
            .iter()
            .find(|(x, _)| *x == m)
            .map_or(&[][..], |(_, s)| s.as_slice())
    };
    let mut out = Vec::with_capacity(data.running.len());
    for p in &mut data.running {
        let dw = window_change(of(p.exponent), check.of(p.exponent), p.row.l_hi, p.row.l_lo);
        fold_pair(p, dw);
        out.push(dw);
    }
    Ok(out)
}

/// [`fold`] applied to a stored pair.
fn fold_pair(p: &mut RefinedPair, dw: f64) {
    let (g, f) = fold(p.row.grid_error, &p.flag, dw, GRID_BOUND);
    p.row.grid_error = g;
    p.flag = f;
}
