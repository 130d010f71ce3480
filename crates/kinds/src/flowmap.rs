//! `flowmap`: the Reynolds current density at one near-critical hard-wall state, at reduced
//! load l = (L − L_c)/L_c < 0 (Figure 6, bottom right).
//!
//! # L_c
//! The critical load is the load above which the contact blocks the flow along `axis` (the
//! fluid, 4-connected, no longer winds around the cell along it; PHYSICS.md). This kind finds it
//! by its own coarse bisection on the surface's grid: hard-wall contact solves (Polonsky–Keer,
//! each warm-started from the largest load known to flow), starting from the bracket
//! [`lo_over_p_fc`·p_fc, p_fc], until the bracket's relative width is below `rel_width`. The
//! `critical` stage kind (crates/critical) computes L_c more carefully (both axes, sub-grid
//! extrapolation); it had not landed when this kind was written, so nothing here depends on
//! it. The bisection's L_c is the grid's own, which is what a map at l ≈ −0.01 on that grid
//! needs: an extrapolated L_c could lie above the grid's and put the state past closure.
//!
//! # Parameters
//! `l` (default −0.01), `axis` (default `x`), `tol` (flow, 1e-10), `max_iter` (flow, 200),
//! `tol_gap` (contact, 1e-10), `rel_width` (bisection, 1e-4), `lo_over_p_fc` (1e-3).
//!
//! # Artefact
//! - datasets `gap`, `contact_pressure`, `pressure` (fluid pressure, NaN in contact and in
//!   removed pools), `current_x`, `current_y` (shape (nx, ny), first index x);
//! - root attributes `lattice`, `n`, `nx`, `ny`, `lx`, `ly`, `p_fc`, `axis`, `l_c` (midpoint of
//!   the final bracket), `l_c_lo`, `l_c_hi`, `l_c_source` ("bisection"), `l` (target), `l_actual`
//!   ((L − L_c)/L_c), `load`, `contact_area`, `flux`, `conductivity`, `percolating`,
//!   `converged` (flow), `termination`, `iterations`, `residual`, `conservation_error`,
//!   `contact_converged`;
//! - `bisection/*`: every probe's `load`, `flows` (u8), `contact_area`, `iterations`,
//!   `converged` (u8).

use crate::solver::{self, SolverParams};
use anyhow::{Result, anyhow, bail};
use contact::{Interaction, Method, Solution};
use formats::gapfile;
use formats::records::Record;
use orchestrator::{
    InputSpec, Inputs, ParamIssue, ParamSpec, ParamType, StageContext, StageReport, TypedKind,
};
use reynolds::{FlowAxis, FlowOptions};
use serde::Deserialize;
use serde_json::json;
use store::{ArtefactWriter, fields};

/// The `flowmap` stage kind.
pub struct FlowMapKind;

/// Bump when the artefact's content changes for the same parameters.
pub const CODE_VERSION: u64 = 4;

/// Whether the fluid (g > 0, 4-connected) winds around the cell along `axis`.
pub fn fluid_flows(gap: &ndarray::Array2<f64>, axis: FlowAxis) -> bool {
    let contact = gap.mapv(|g| g <= 0.0);
    let d = percolation::dual_percolation(contact.view());
    d.fluid_percolates(match axis {
        FlowAxis::X => percolation::Axis::X,
        FlowAxis::Y => percolation::Axis::Y,
    })
}

formats::record! {
    /// One contact solve of the bisection (`bisection/*`).
    #[derive(Clone, Debug, PartialEq)]
    pub struct Probe {
        /// Mean pressure (E* h0/λ).
        pub load: f64,
        /// The fluid winds along the axis.
        pub flows: bool,
        /// Relative contact area.
        pub contact_area: f64,
        /// Minimiser iterations.
        pub iterations: usize,
        /// The contact solve converged.
        pub converged: bool,
    }
}

/// The `flowmap` kind's parameters.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FlowMapParams {
    /// Reduced load (L − L_c)/L_c of the state, < 0.
    pub l: f64,
    /// Flow direction.
    #[serde(deserialize_with = "crate::flow::de_axis")]
    pub axis: FlowAxis,
    /// Flow: target true relative residual.
    pub tol: f64,
    /// Flow: cap on preconditioned CG iterations.
    pub max_iter: usize,
    /// Contact: constraint-violation tolerance (h0).
    pub tol_gap: f64,
    /// Contact: iteration cap per solve.
    pub max_iter_contact: usize,
    /// Bisection: stop when (hi − lo)/hi is below this.
    pub rel_width: f64,
    /// Bisection: lower end of the initial bracket, in p_fc.
    pub lo_over_p_fc: f64,
}

impl FlowMapParams {
    /// The contact solver's parameters (Polonsky–Keer: hard wall).
    pub fn solver(&self) -> SolverParams {
        SolverParams {
            tol_gap: self.tol_gap,
            max_iter: self.max_iter_contact,
            method: Method::PolonskyKeer,
            ..SolverParams::default()
        }
    }
}

impl TypedKind for FlowMapKind {
    type Params = FlowMapParams;
    /// Lower bound: heights, displacement, pressure and gap of the contact solve on the
    /// surface's grid (the flow solve after it reuses as much).
    fn memory_estimate(
        &self,
        _params: &orchestrator::Params,
        inputs: &std::collections::BTreeMap<String, Vec<orchestrator::Params>>,
    ) -> Option<u64> {
        let n = orchestrator::upstream_max(inputs, &["n"])?;
        Some(4 * crate::surface::field_bytes(n))
    }
    fn name(&self) -> &str {
        "flowmap"
    }
    fn code_version(&self) -> u64 {
        CODE_VERSION
    }
    fn doc(&self) -> &str {
        "current density of the Reynolds flow at a near-critical hard-wall state (l < 0)"
    }
    fn params(&self) -> Vec<ParamSpec> {
        let open01 = |max: f64| ParamType::Float {
            min: Some(0.0),
            min_exclusive: true,
            max: Some(max),
            max_exclusive: false,
        };
        vec![
            ParamSpec::new(
                "l",
                ParamType::Float {
                    min: Some(-0.9),
                    min_exclusive: false,
                    max: Some(0.0),
                    max_exclusive: true,
                },
            )
            .default(-0.01)
            .doc("reduced load (L − L_c)/L_c of the state, < 0 (the fluid still flows)"),
            ParamSpec::new("axis", ParamType::one_of(&["x", "y"]))
                .default("x")
                .doc("flow direction; L_c is the load above which flow along it stops"),
            ParamSpec::new("tol", open01(1e-3))
                .default(1e-10)
                .doc("flow: target true relative residual"),
            ParamSpec::new("max_iter", ParamType::int_range(1, 100_000))
                .default(200)
                .doc("flow: cap on preconditioned CG iterations"),
            solver::tol_gap_spec(),
            solver::max_iter_spec("max_iter_contact"),
            ParamSpec::new("rel_width", open01(0.1))
                .default(1e-4)
                .doc("bisection: stop when (hi − lo)/hi is below this"),
            ParamSpec::new("lo_over_p_fc", open01(0.5))
                .default(1e-3)
                .doc("bisection: lower end of the initial bracket, in p_fc"),
        ]
    }
    fn check(&self, params: &FlowMapParams) -> Result<(), ParamIssue> {
        let (l, w) = (params.l, params.rel_width);
        if w >= l.abs() / 2.0 {
            return Err(ParamIssue::new(
                "rel_width",
                format!(
                    "{w}: must be below |l|/2 = {} so that the state lies below the bracket",
                    l.abs() / 2.0
                ),
            ));
        }
        Ok(())
    }
    fn inputs(&self, _params: &FlowMapParams) -> Vec<InputSpec> {
        vec![InputSpec::one("surface", &["surface"]).doc("the surface (hard wall)")]
    }
    fn cost(&self, params: &FlowMapParams) -> f64 {
        (1.0 / params.rel_width).log2().ceil() * 0.05
    }
    fn run(
        &self,
        ctx: &mut StageContext,
        params: &FlowMapParams,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        let mut surface = crate::surface::SurfaceInput::read(inputs.one("surface")?)?;
        let b = bisect(ctx, &mut surface, params)?;
        let l_c = 0.5 * (b.lo + b.hi);
        let unconverged = b.probes.iter().filter(|p| !p.converged).count();
        if unconverged > 0 {
            ctx.warn(format!(
                "{unconverged} of {} contact solves of the bisection did not converge: L_c may \
                 be off",
                b.probes.len()
            ));
        }

        // the state and its flow
        let load = l_c * (1.0 + params.l);
        let state = solve(&mut surface.model, params, load, Some(&b.lo_state))?;
        if !state.stats.converged {
            ctx.warn(format!(
                "the contact solve at L = {load} did not converge ({} iterations)",
                state.stats.iterations
            ));
        }
        let res = flow_at(ctx, &surface, params, &state, load, l_c)?;
        ctx.progress(0.95, "writing");
        write_artefact(out, &surface, params, &b, (load, &state), &res)?;
        Ok(StageReport::with_stats(json!({
            "l_c": l_c,
            "l_c_over_p_fc": l_c / surface.p_fc,
            "l_c_bracket": [b.lo, b.hi],
            "l_c_source": "bisection",
            "probes": b.probes.len(),
            "contact_iterations_total": b.probes.iter().map(|p| p.iterations).sum::<usize>(),
            "load": load,
            "flow": gapfile::flow_json(&res),
        })))
    }
}

/// A hard-wall solve at mean pressure `load`, warm-started from `warm`.
fn solve(
    model: &mut contact::Model,
    params: &FlowMapParams,
    load: f64,
    warm: Option<&Solution>,
) -> Result<Solution> {
    model
        .solve(
            Interaction::HardWall,
            load,
            &params.solver().options(),
            warm,
        )
        .map_err(|e| anyhow!("hard-wall contact at mean pressure {load}: {e}"))
}

/// The final bracket [lo, hi] of L_c, the state at `lo` (flowing) and every probe.
struct Bisection {
    lo: f64,
    hi: f64,
    lo_state: Solution,
    probes: Vec<Probe>,
}

/// L_c by bisection between `lo_over_p_fc` p_fc (the fluid must flow) and p_fc (it must not),
/// each probe warm-started from the last flowing state.
fn bisect(
    ctx: &mut StageContext,
    surface: &mut crate::surface::SurfaceInput,
    params: &FlowMapParams,
) -> Result<Bisection> {
    let (lattice, n_exp, p_fc, axis) = (
        surface.lattice.clone(),
        surface.n,
        surface.p_fc,
        params.axis,
    );
    let model = &mut surface.model;
    let mut probes: Vec<Probe> = Vec::new();
    let record = |probes: &mut Vec<Probe>, load: f64, s: &Solution| -> bool {
        let flows = fluid_flows(&s.gap, axis);
        probes.push(Probe {
            load,
            flows,
            contact_area: s.contact_area,
            iterations: s.stats.iterations,
            converged: s.stats.converged,
        });
        flows
    };
    let mut lo = params.lo_over_p_fc * p_fc;
    let mut hi = p_fc;
    let mut lo_state = solve(model, params, lo, None)?;
    if !record(&mut probes, lo, &lo_state) {
        bail!(
            "{lattice} n = {n_exp}: the fluid does not flow along {} even at the bracket's \
             lower end {lo} (lo_over_p_fc = {}); lower `lo_over_p_fc`",
            gapfile::axis_name(axis),
            params.lo_over_p_fc
        );
    }
    let hi_state = solve(model, params, hi, Some(&lo_state))?;
    if record(&mut probes, hi, &hi_state) {
        bail!(
            "{lattice} n = {n_exp}: the fluid still flows along {} at the full-contact \
             pressure p_fc = {p_fc}; no critical load below it",
            gapfile::axis_name(axis)
        );
    }
    drop(hi_state);
    let steps = ((1.0 / params.rel_width).log2().ceil() as usize).max(1) + 2;
    let mut k = 0;
    while (hi - lo) > params.rel_width * hi {
        let mid = 0.5 * (lo + hi);
        let s = solve(model, params, mid, Some(&lo_state))?;
        if record(&mut probes, mid, &s) {
            lo = mid;
            lo_state = s;
        } else {
            hi = mid;
        }
        k += 1;
        ctx.progress(
            (k as f64 / steps as f64).min(0.9),
            &format!("L_c in [{lo:.6}, {hi:.6}]"),
        );
    }
    Ok(Bisection {
        lo,
        hi,
        lo_state,
        probes,
    })
}

/// The flow through the state's gap, with its fields; warnings when it did not converge or
/// does not flow.
fn flow_at(
    ctx: &mut StageContext,
    surface: &crate::surface::SurfaceInput,
    params: &FlowMapParams,
    state: &Solution,
    load: f64,
    l_c: f64,
) -> Result<reynolds::FlowResult> {
    let fopts = FlowOptions {
        tolerance: params.tol,
        max_iterations: params.max_iter,
        return_fields: true,
        ..Default::default()
    };
    let res = reynolds::solve(
        state.gap.view(),
        surface.lx,
        surface.ly,
        params.axis,
        &fopts,
    )
    .map_err(|e| anyhow!("flow at L = {load}: {e}"))?;
    if !res.converged {
        ctx.warn(format!(
            "the flow solve at L = {load} did not converge ({} after {} iterations, \
             residual {:.2e}): the map is flagged converged = false",
            gapfile::termination_name(res.termination),
            res.iterations,
            res.relative_residual
        ));
    }
    if !res.percolating {
        let l = params.l;
        ctx.warn(format!(
            "the fluid does not flow at L = {load} (l = {l}), below the bisection's L_c = \
             {l_c}: the flow is not monotonic in the load on this grid"
        ));
    }
    Ok(res)
}

/// The fields, the attributes and the bisection's probes.
fn write_artefact(
    out: &mut ArtefactWriter,
    surface: &crate::surface::SurfaceInput,
    params: &FlowMapParams,
    b: &Bisection,
    (load, state): (f64, &Solution),
    res: &reynolds::FlowResult,
) -> Result<()> {
    let f = res.fields.as_ref().expect("fields requested");
    let l_c = 0.5 * (b.lo + b.hi);
    out.set_cell(surface.lx, surface.ly)?;
    out.write_f64_2d(fields::GAP, state.gap.view())?;
    out.write_f64_2d("contact_pressure", state.pressure.view())?;
    out.write_f64_2d(fields::PRESSURE, f.pressure.view())?;
    out.write_f64_2d(fields::CURRENT_X, f.current_x.view())?;
    out.write_f64_2d(fields::CURRENT_Y, f.current_y.view())?;
    out.set_attr("lattice", surface.lattice.as_str())?;
    out.set_attr("n", surface.n)?;
    out.set_attr("nx", surface.nx as i64)?;
    out.set_attr("ny", surface.ny as i64)?;
    out.set_attr("p_fc", surface.p_fc)?;
    out.set_attr("axis", gapfile::axis_name(params.axis))?;
    out.set_attr("l_c", l_c)?;
    out.set_attr("l_c_lo", b.lo)?;
    out.set_attr("l_c_hi", b.hi)?;
    out.set_attr("l_c_source", "bisection")?;
    out.set_attr("l", params.l)?;
    out.set_attr("l_actual", (load - l_c) / l_c)?;
    out.set_attr("load", load)?;
    out.set_attr("contact_area", state.contact_area)?;
    out.set_attr("contact_converged", state.stats.converged)?;
    for (k, v) in gapfile::flow_json(res).as_object().expect("object") {
        match v {
            serde_json::Value::Bool(b) => out.set_attr(k, *b)?,
            serde_json::Value::String(s) => out.set_attr(k, s.as_str())?,
            serde_json::Value::Number(x) if x.is_f64() => {
                out.set_attr(k, x.as_f64().unwrap_or(f64::NAN))?
            }
            serde_json::Value::Number(x) => out.set_attr(k, x.as_i64().unwrap_or_default())?,
            _ => {}
        }
    }
    Probe::write(&b.probes, out, "bisection")
}
