//! `ladder`: hard-wall solves at reduced loads l = (L − L_c)/L_c around the critical load of one
//! model, on one or more unshifted 2^n grids (coarse to fine, each level warm-started from the
//! one before), keeping a window of the gap and the contact pressure around one saddle and the
//! Reynolds flux through the cell (crates/critical/src/ladder.rs).
//!
//! # L_c
//! From the `critical` input, level by level: every ladder grid n must be a level of that stage
//! (same model, computed on the unshifted grid — `shifts = 0` — so that its L_c belongs to the
//! very grid the ladder solves on). With `l_c = "subgrid"` (default) the sub-grid L_c
//! (saddle-gap fit) is used where the level has one, else the grid's bisected L_c; with
//! `l_c = "grid"` always the grid's bisected L_c (`l_c_source` says which was used). The
//! choice matters below |l| ≈ 1e-3: on 2^10 and 2^11 the sub-grid L_c lies ≈ 1e-4 (relative)
//! above the load at which the grid's saddle closes, and a bias δ in L_c turns the local slope
//! of the saddle gap into ζ ln((|l₁|−δ)/(|l₂|−δ)) / ln(|l₁|/|l₂|): shared by both grids, it
//! is invisible to the grid error (docs/near-critical.md, "L_c: each grid's bisected L_c").
//!
//! # Parameters
//! `ns` (ascending grid exponents), `ls` (reduced loads, default the paper's ±0.002, ±0.005,
//! ±0.01, ±0.02 plus 0 for the contact line at L_c), `window` (half-size of the stored window
//! around the saddle, λ), `tol_gap` (Polonsky–Keer, h0), `flow` (Reynolds flux along the channel
//! and across it at every rung but l = 0), `flow_tol`.
//!
//! # The flux at l = 0
//! The rung at L_c itself gets no flow solve (flux and conductivities NaN, `percolating` and
//! `flow_converged` false; since session #20). Its saddle gap is zero or at the contact solver's
//! tolerance (g_s ≤ 1e-10 h0), so the conductivity g³ at the throat is ≤ 1e-30 of the cell's:
//! the preconditioned CG stopped there on residual growth or at its rounding limit after 5–142
//! iterations on every model, and each draft run warned "the flow solve did not converge" for
//! the hexagonal and triangular ladders. No table, figure or fit reads the flux at l = 0 (the
//! exponents, Figure 6, the running exponents and the random-constriction comparison take
//! l < 0 only; Figure 5 takes the contact line at l = 0, not its flux).
//!
//! # Artefact
//! - root attributes `lattice`, `ns`, `ls`, `window`, `l_c` (finest level), `saddle_x`,
//!   `saddle_y` (λ), `channel_axis` ("x"/"y": the flow through the saddle and the flux's
//!   direction), `eta`, `saddle_height`, cell `lx`, `ly`;
//! - per level `level/<n>`: attributes `n`, `nx`, `ny`, `l_c`, `l_c_source` ("subgrid" or
//!   "grid"), `l_c_grid`, `d_par`, `d_perp` (window spacings along and across the channel, λ),
//!   `wall_s`, `iterations`; datasets (one entry per rung, ascending l: the columns of
//!   [`RungRow`]) `l`, `load`, `contact_area`, `saddle_gap`, `iterations`, `converged`,
//!   `retried`, `flux` (Q for a unit pressure drop across the cell), `conductivity`
//!   (K = Q L_flow / L_cross), `percolating`, `flow_converged` and, for the flow along the other
//!   grid axis, `conductivity_across`, `percolating_across`, `flow_across_converged` (the
//!   isotropy check of β: K_along = K_across in the continuum, `critical::running`); windows
//!   `rung/<k>/gap`,
//!   `rung/<k>/pressure` (first index along the channel, saddle at the centre).

use crate::critical::CriticalLevel;
use crate::surface::lattice_from_name;
use anyhow::{Context, Result, anyhow, bail};
use contact::Solution;
use critical::ladder::{LadderOptions, Rung, Window, axis_saddle, solve_ladder};
use formats::records::{Record, read_in};
use orchestrator::{
    InputSpec, Inputs, ParamIssue, ParamSpec, ParamType, StageContext, StageReport, TypedKind,
};
use reynolds::{FlowAxis, FlowOptions};
use serde::Deserialize;
use serde_json::json;
use store::{ArtefactReader, ArtefactWriter};
use surface::{Lattice, Surface};

/// The `ladder` stage kind.
pub struct LadderKind;

/// Bump when the artefact's content changes for the same parameters.
pub const CODE_VERSION: u64 = 4;

/// The paper's ladder, plus l = 0 (the contact line at L_c).
pub const DEFAULT_LS: [f64; 9] = [-0.02, -0.01, -0.005, -0.002, 0.0, 0.002, 0.005, 0.01, 0.02];

/// The `ladder` kind's parameters.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LadderParams {
    /// Grid exponents, strictly ascending; each a level of the `critical` input.
    pub ns: Vec<u32>,
    /// Reduced loads (L − L_c)/L_c, distinct.
    pub ls: Vec<f64>,
    /// Half-size of the stored window around the saddle (λ).
    pub window: f64,
    /// Polonsky–Keer tolerance on the constraint violation (h0).
    pub tol_gap: f64,
    /// Reynolds flux at every rung.
    pub flow: bool,
    /// Which L_c of the `critical` input: "subgrid" (where available) or "grid".
    pub l_c: String,
    /// Flow: target true relative residual.
    pub flow_tol: f64,
}

impl TypedKind for LadderKind {
    type Params = LadderParams;
    /// Lower bound: heights, displacement, pressure and gap on the finest grid of the ladder.
    fn memory_estimate(
        &self,
        params: &orchestrator::Params,
        _inputs: &std::collections::BTreeMap<String, Vec<orchestrator::Params>>,
    ) -> Option<u64> {
        let n = crate::critical::ns(params).ok()?.into_iter().max()?;
        Some(4 * crate::surface::field_bytes(n as i64))
    }
    fn name(&self) -> &str {
        "ladder"
    }
    fn code_version(&self) -> u64 {
        CODE_VERSION
    }
    fn doc(&self) -> &str {
        "hard-wall solves at reduced loads around L_c (from a `critical` input), warm-started, coarse to fine; window around one saddle and the flux per rung"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            crate::critical::ns_spec(
                6,
                "grid exponents, strictly ascending; each a level of the `critical` input",
            ),
            ParamSpec::new(
                "ls",
                ParamType::Array {
                    elem: Box::new(ParamType::float_range(-0.5, 0.5)),
                    min_len: 1,
                    max_len: Some(64),
                },
            )
            .default(json!(DEFAULT_LS))
            .doc("reduced loads (L − L_c)/L_c, distinct, in [−0.5, 0.5]"),
            ParamSpec::new("window", ParamType::float_range(0.005, 0.5))
                .default(0.12)
                .doc("half-size of the stored window around the saddle (λ)"),
            crate::solver::tol_gap_spec(),
            ParamSpec::new("flow", ParamType::Bool)
                .default(true)
                .doc("Reynolds flux through the cell along the saddle's channel, and across it (isotropy check), at every rung"),
            ParamSpec::new("l_c", ParamType::one_of(&["subgrid", "grid"]))
                .default("subgrid")
                .doc("L_c of each level: the sub-grid L_c (saddle-gap fit) where available, or the grid's bisected L_c"),
            ParamSpec::new("flow_tol", ParamType::float_range(1e-14, 1e-3))
                .default(1e-10)
                .doc("flow: target true relative residual"),
        ]
    }
    fn check(&self, params: &LadderParams) -> Result<(), ParamIssue> {
        crate::critical::check_ascending(&params.ns)?;
        check_distinct_ls(&params.ls)
    }
    fn inputs(&self, _params: &LadderParams) -> Vec<InputSpec> {
        vec![
            InputSpec::one("critical", &["critical"])
                .doc("L_c of the model on the ladder's grids (unshifted: shifts = 0)"),
        ]
    }
    fn cost(&self, params: &LadderParams) -> f64 {
        let k = params.ls.len() as f64;
        params
            .ns
            .iter()
            .map(|&n| 4f64.powi(n as i32) / 4f64.powi(9) * k * 0.5)
            .sum()
    }
    fn run(
        &self,
        ctx: &mut StageContext,
        params: &LadderParams,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        let crit = inputs.one("critical")?;
        let levels = CriticalLevel::read_all(crit)?;
        let lattice = levels[0].lattice;
        let ns = &params.ns;
        let mut ls = params.ls.clone();
        ls.sort_by(f64::total_cmp);
        let opts = LadderOptions {
            tol_gap: params.tol_gap,
            window: params.window,
            ..Default::default()
        };
        let fopts = FlowOptions {
            tolerance: params.flow_tol,
            ..Default::default()
        };
        // L_c per level, checked before any solve
        let l_cs = level_l_cs(ctx, params, crit, &levels)?;

        let weights: Vec<f64> = ns.iter().map(|&n| 4f64.powi(n as i32)).collect();
        let total: f64 = weights.iter().sum();
        let mut done = 0.0;
        let mut coarse: Option<Vec<Solution>> = None;
        let mut frame0 = None;
        let mut unconverged = 0usize;
        let mut not_flowing = Vec::new();
        let mut per_level = Vec::new();
        for (k, &n) in ns.iter().enumerate() {
            let t0 = std::time::Instant::now();
            let s = Surface::new(lattice, n)?;
            let frame = axis_saddle(&s)?;
            let (l_c, source, _) = l_cs[k];
            let keep = k + 1 < ns.len();
            let step = LevelStep {
                n,
                s: &s,
                frame: &frame,
                l_c,
                ls: &ls,
                opts: &opts,
                fopts: params.flow.then_some(&fopts),
                keep,
                progress: (done, weights[k], total),
            };
            let (rungs, flows, kept) = solve_level(ctx, &step, coarse.as_deref())?;
            done += weights[k];
            coarse = keep.then_some(kept);
            let at = format!("level/{n}");
            write_level(out, &at, &rungs, params.flow.then_some(&flows[..]))?;
            let wall = t0.elapsed().as_secs_f64();
            let iterations = write_level_attrs(out, &at, n, &s, l_cs[k], &rungs, wall)?;
            unconverged += rungs.iter().filter(|r| !r.converged).count();
            if params.flow {
                check_flows(ctx, n, &rungs, &flows, &mut not_flowing);
            }
            per_level.push(json!({
                "n": n, "l_c": l_c, "l_c_source": source, "iterations": iterations, "wall_s": wall,
            }));
            frame0 = Some((frame, s.grid));
        }
        warn_summary(ctx, unconverged, &not_flowing);
        let (frame, grid) = frame0.expect("at least one level");
        out.set_cell(grid.lx, grid.ly)?;
        out.set_attr("lattice", lattice.name())?;
        out.set_attr("ns", json!(ns))?;
        out.set_attr("ls", json!(ls))?;
        write_frame(out, opts.window, l_cs.last().expect("levels").0, &frame)?;
        ctx.progress(1.0, "written");
        Ok(StageReport::with_stats(json!({ "levels": per_level })))
    }
}

/// `ls` (key `ls`, any order) without a repeated reduced load: the ladder's and the refined
/// ladders' check.
pub(crate) fn check_distinct_ls(ls: &[f64]) -> Result<(), ParamIssue> {
    let mut ls = ls.to_vec();
    ls.sort_by(f64::total_cmp);
    if ls.windows(2).any(|w| w[1] == w[0]) {
        return Err(ParamIssue::new(
            "ls",
            format!("{ls:?}: allowed distinct reduced loads"),
        ));
    }
    Ok(())
}

/// (L_c, its source, the grid's bisected L_c) for every ladder grid, from the `critical` input.
fn level_l_cs(
    ctx: &mut StageContext,
    params: &LadderParams,
    crit: &ArtefactReader,
    levels: &[CriticalLevel],
) -> Result<Vec<(f64, &'static str, f64)>> {
    let mut l_cs = Vec::new();
    for &n in &params.ns {
        let lv = levels.iter().find(|l| l.n == n).ok_or_else(|| {
            anyhow!(
                "ns: grid n = {n} is not a level of the `critical` input `{}` (levels {:?}); \
                 add it to that stage's `ns`",
                crit.path().display(),
                levels.iter().map(|l| l.n).collect::<Vec<_>>()
            )
        })?;
        lv.require_unshifted(crit.path(), "the ladder")?;
        let grid = lv.get("l_c").map(|v| v.0).unwrap_or(f64::NAN);
        let (l_c, source) = if params.l_c == "grid" {
            (grid, "grid")
        } else if lv.l_c_subgrid.0.is_finite() {
            (lv.l_c_subgrid.0, "subgrid")
        } else {
            ctx.warn(format!(
                "n = {n}: no sub-grid L_c (the channel is not resolved at the saddle-gap \
                 samples); using the grid's bisected L_c"
            ));
            (grid, "grid")
        };
        l_cs.push((l_c, source, grid));
    }
    Ok(l_cs)
}

/// One grid of the ladder: what [`solve_level`] needs.
struct LevelStep<'a> {
    n: u32,
    s: &'a Surface,
    frame: &'a critical::ladder::SaddleFrame,
    l_c: f64,
    ls: &'a [f64],
    opts: &'a LadderOptions,
    /// Flow options; `None` without flow.
    fopts: Option<&'a FlowOptions>,
    /// Keep every rung's solution (to warm-start the next, finer grid).
    keep: bool,
    /// (work done before this level, this level's weight, total weight) for the progress bar.
    progress: (f64, f64, f64),
}

/// (flux Q, conductivity K, percolating, converged) of one rung's flow solve.
type AxisFlow = (f64, f64, bool, bool);

/// One rung's flow solves: along the saddle's channel, and along the other grid axis.
type RungFlow = [AxisFlow; 2];

/// The flow of a rung without a flow solve: flux and conductivity NaN, not percolating, not
/// converged.
const NO_FLOW: AxisFlow = (f64::NAN, f64::NAN, false, false);

/// Solves the ladder on one grid (warm-started from `coarse`) and the flux at every rung.
fn solve_level(
    ctx: &mut StageContext,
    step: &LevelStep,
    coarse: Option<&[Solution]>,
) -> Result<(Vec<Rung>, Vec<RungFlow>, Vec<Solution>)> {
    let (s, n) = (step.s, step.n);
    let axes = if step.frame.channel_axis == 0 {
        [FlowAxis::X, FlowAxis::Y]
    } else {
        [FlowAxis::Y, FlowAxis::X]
    };
    let (done, weight, total) = step.progress;
    let mut kept = Vec::new();
    let mut flows = Vec::new();
    let mut flow_err: Option<anyhow::Error> = None;
    let nr = step.ls.len();
    let rungs = {
        let mut on_rung = |r: &Rung, sol: &Solution| {
            if step.keep {
                kept.push(sol.clone());
            }
            if step.fopts.is_some() && r.l == 0.0 {
                // L_c itself: no flow solve (module docs, "The flux at l = 0")
                flows.push([NO_FLOW; 2]);
            } else if let Some(fopts) = step.fopts
                && flow_err.is_none()
            {
                let solve =
                    |axis| reynolds::solve(sol.gap.view(), s.grid.lx, s.grid.ly, axis, fopts);
                match (solve(axes[0]), solve(axes[1])) {
                    (Ok(a), Ok(b)) => flows.push([
                        (a.flux, a.conductivity, a.percolating, a.converged),
                        (b.flux, b.conductivity, b.percolating, b.converged),
                    ]),
                    (Err(e), _) | (_, Err(e)) => {
                        flow_err = Some(anyhow!("flow at n = {n}, l = {}: {e}", r.l));
                    }
                }
            }
            let f = (flows.len().max(1) as f64) / nr as f64;
            ctx.progress(
                0.95 * (done + f * weight) / total,
                &format!("n = {n}, l = {:+}", r.l),
            );
        };
        solve_ladder(
            s,
            step.frame,
            step.l_c,
            step.ls,
            step.opts,
            coarse,
            &mut on_rung,
        )
        .with_context(|| format!("{} ladder on n = {n}", s.lattice.name()))?
    };
    if let Some(e) = flow_err {
        return Err(e);
    }
    Ok((rungs, flows, kept))
}

/// The attributes of `level/<n>`; returns the level's contact iterations.
fn write_level_attrs(
    out: &mut ArtefactWriter,
    at: &str,
    n: u32,
    s: &Surface,
    (l_c, source, l_c_grid): (f64, &str, f64),
    rungs: &[Rung],
    wall: f64,
) -> Result<usize> {
    out.set_attr_at(at, "n", n as i64)?;
    out.set_attr_at(at, "nx", s.grid.nx as i64)?;
    out.set_attr_at(at, "ny", s.grid.ny as i64)?;
    out.set_attr_at(at, "l_c", l_c)?;
    out.set_attr_at(at, "l_c_source", source)?;
    out.set_attr_at(at, "l_c_grid", l_c_grid)?;
    out.set_attr_at(at, "d_par", rungs[0].window.d_par)?;
    out.set_attr_at(at, "d_perp", rungs[0].window.d_perp)?;
    let iterations: usize = rungs.iter().map(|r| r.iterations).sum();
    out.set_attr_at(at, "iterations", iterations as i64)?;
    out.set_attr_at(at, "wall_s", wall)?;
    Ok(iterations)
}

/// Warns on unconverged flow solves; collects rungs below L_c where the fluid does not percolate.
fn check_flows(
    ctx: &mut StageContext,
    n: u32,
    rungs: &[Rung],
    flows: &[RungFlow],
    not_flowing: &mut Vec<String>,
) {
    for (r, [(_, _, p, c), (_, _, p_across, c_across)]) in rungs.iter().zip(flows) {
        if r.l < 0.0 && !p {
            not_flowing.push(format!("n = {n}, l = {}", r.l));
        }
        if !c && *p {
            ctx.warn(format!(
                "n = {n}, l = {}: the flow solve did not converge",
                r.l
            ));
        }
        if !c_across && *p_across {
            ctx.warn(format!(
                "n = {n}, l = {}: the flow solve across the channel did not converge",
                r.l
            ));
        }
    }
}

/// The run's closing warnings: unconverged contact solves, no flow below L_c.
fn warn_summary(ctx: &mut StageContext, unconverged: usize, not_flowing: &[String]) {
    if unconverged > 0 {
        ctx.warn(format!(
            "{unconverged} rungs did not converge (contact solver): their windows are stored \
             with converged = 0"
        ));
    }
    if !not_flowing.is_empty() {
        ctx.warn(format!(
            "the fluid does not percolate below L_c at {}: the grid closes the channel \
             before the sub-grid L_c",
            not_flowing.join("; ")
        ));
    }
}

/// The root attributes `window`, `l_c` (finest level) and the saddle's.
fn write_frame(
    out: &mut ArtefactWriter,
    window: f64,
    l_c: f64,
    frame: &critical::ladder::SaddleFrame,
) -> Result<()> {
    out.set_attr("window", window)?;
    out.set_attr("l_c", l_c)?;
    out.set_attr("saddle_x", frame.x)?;
    out.set_attr("saddle_y", frame.y)?;
    out.set_attr(
        "channel_axis",
        if frame.channel_axis == 0 { "x" } else { "y" },
    )?;
    out.set_attr("eta", frame.eta)?;
    out.set_attr("saddle_height", frame.height)?;
    Ok(())
}

/// The rungs of one level (`<at>/*`, one [`RungRow`] each) and their windows (`<at>/rung/<k>/*`).
fn write_level(
    out: &mut ArtefactWriter,
    at: &str,
    rungs: &[Rung],
    flows: Option<&[RungFlow]>,
) -> Result<()> {
    let rows: Vec<RungRow> = rungs
        .iter()
        .enumerate()
        .map(|(k, r)| RungRow::of(r, flows.and_then(|f| f.get(k).copied())))
        .collect();
    RungRow::write(&rows, out, at)?;
    for (k, r) in rungs.iter().enumerate() {
        out.write_f64_2d(&format!("{at}/rung/{k}/gap"), r.window.gap.view())?;
        out.write_f64_2d(&format!("{at}/rung/{k}/pressure"), r.window.pressure.view())?;
    }
    Ok(())
}

formats::record! {
    /// One rung of a level (`level/<n>/*`, ascending l).
    #[derive(Clone, Debug, PartialEq)]
    pub struct RungRow {
        /// Reduced load (L − L_c)/L_c.
        pub l: f64,
        /// Load (E* h0/λ).
        pub load: f64,
        /// Contact area fraction.
        pub contact_area: f64,
        /// Gap at the saddle (h0).
        pub saddle_gap: f64,
        /// Contact-solver iterations.
        pub iterations: usize,
        /// The contact solve converged.
        pub converged: bool,
        /// The contact solve was retried.
        pub retried: bool,
        /// Flux through the cell along the channel (NaN without flow).
        pub flux: f64,
        /// Conductivity along the channel, K = Q L_flow / L_cross (NaN without flow).
        pub conductivity: f64,
        /// The fluid percolates along the channel axis (false without flow).
        pub percolating: bool,
        /// The flow solve converged (false without flow).
        pub flow_converged: bool,
        /// Conductivity along the other grid axis (NaN without flow).
        pub conductivity_across: f64,
        /// The fluid percolates along the other grid axis (false without flow).
        pub percolating_across: bool,
        /// The flow solve along the other axis converged (false without flow).
        pub flow_across_converged: bool,
    }
}

impl RungRow {
    /// Rung `r` with its flow solve, if any.
    fn of(r: &Rung, flow: Option<RungFlow>) -> Self {
        let [
            (flux, conductivity, percolating, flow_converged),
            (_, conductivity_across, percolating_across, flow_across_converged),
        ] = flow.unwrap_or([NO_FLOW; 2]);
        RungRow {
            l: r.l,
            load: r.load,
            contact_area: r.contact_area,
            saddle_gap: r.window.saddle_gap(),
            iterations: r.iterations,
            converged: r.converged,
            retried: r.retried,
            flux,
            conductivity,
            percolating,
            flow_converged,
            conductivity_across,
            percolating_across,
            flow_across_converged,
        }
    }
}

/// One rung as read back.
#[derive(Clone, Debug)]
pub struct RungData {
    /// Reduced load.
    pub l: f64,
    /// Load (E* h0/λ).
    pub load: f64,
    /// Contact area fraction.
    pub contact_area: f64,
    /// Flux through the cell along the channel (NaN without flow).
    pub flux: f64,
    /// The fluid percolates along the channel axis.
    pub percolating: bool,
    /// The flow solve converged (false without flow).
    pub flow_converged: bool,
    /// Conductivity along the channel (NaN without flow).
    pub conductivity: f64,
    /// Conductivity along the other grid axis where the fluid percolates that way and the
    /// solve converged, else NaN.
    pub conductivity_across: f64,
    /// The contact solve converged.
    pub converged: bool,
    /// The window around the saddle.
    pub window: Window,
}

/// One grid of a ladder as read back.
#[derive(Clone, Debug)]
pub struct LadderLevel {
    /// Grid exponent.
    pub n: u32,
    /// The L_c the reduced loads refer to.
    pub l_c: f64,
    /// "subgrid" or "grid".
    pub l_c_source: String,
    /// Rungs, ascending l.
    pub rungs: Vec<RungData>,
}

/// A `ladder` artefact as read back.
#[derive(Clone, Debug)]
pub struct LadderData {
    /// Model.
    pub lattice: Lattice,
    /// Curvature ratio of the saddle.
    pub eta: f64,
    /// Levels, ascending n.
    pub levels: Vec<LadderLevel>,
}

impl LadderData {
    /// Reads a `ladder` artefact.
    pub fn read(r: &ArtefactReader) -> Result<Self> {
        let lattice = lattice_from_name(&r.attr_str("lattice")?)?;
        let mut levels = Vec::new();
        for name in r.members("level")? {
            let at = format!("level/{name}");
            let rows: Vec<RungRow> = read_in(r, &at)?;
            let (d_par, d_perp) = (r.attr_f64_at(&at, "d_par")?, r.attr_f64_at(&at, "d_perp")?);
            let mut rungs = Vec::new();
            for (k, row) in rows.into_iter().enumerate() {
                rungs.push(RungData {
                    l: row.l,
                    load: row.load,
                    contact_area: row.contact_area,
                    flux: row.flux,
                    percolating: row.percolating,
                    flow_converged: row.flow_converged,
                    conductivity: row.conductivity,
                    conductivity_across: if row.percolating_across && row.flow_across_converged {
                        row.conductivity_across
                    } else {
                        f64::NAN
                    },
                    converged: row.converged,
                    window: Window {
                        d_par,
                        d_perp,
                        gap: r.read_f64_2d(&format!("{at}/rung/{k}/gap"))?,
                        pressure: r.read_f64_2d(&format!("{at}/rung/{k}/pressure"))?,
                    },
                });
            }
            levels.push(LadderLevel {
                n: r.attr_i64_at(&at, "n")? as u32,
                l_c: r.attr_f64_at(&at, "l_c")?,
                l_c_source: r.attr_str_at(&at, "l_c_source")?,
                rungs,
            });
        }
        if levels.is_empty() {
            bail!("{} has no ladder levels", r.path().display());
        }
        levels.sort_by_key(|l| l.n);
        Ok(LadderData {
            lattice,
            eta: r.attr_f64("eta")?,
            levels,
        })
    }
}
