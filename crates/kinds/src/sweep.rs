//! `sweep`: a quasi-static path on one surface — loading then unloading in the mean pressure, or
//! increasing then decreasing interaction strength (γ0, γr) at a fixed load.
//!
//! # Parameters
//! - `interaction`: `hardwall`, `adhesion` (γ = −γ0 e^(−g/ρ)) or `repulsion` (γ = γr e^(−g²/2ρ²));
//!   `gamma0`, `gamma_r`, `rho` (defaults 0.2, 0.2, 0.04: PHYSICS.md; only the ones of the chosen
//!   interaction matter).
//! - `control`: `load` (the path varies the mean pressure) or `strength` (it varies γ0 or γr at
//!   the fixed mean pressure `load`).
//! - `unit`: `p_fc` (loads in units of the surface's full-contact pressure p_fc on its grid, the
//!   default) or `absolute` (E* h0/λ). Strengths are always absolute (E* h0²/λ).
//! - `path`: the forward branch as a list of segments, each `{ from, to, steps }` or
//!   `{ from, to, step }` (`from` only in the first segment; a segment starts where the previous
//!   one ends). A segment contributes the values from + (to − from)·k/steps, k = 1..=steps
//!   (`step` gives steps = ⌈(to − from)/step⌉); the first segment also contributes `from`. So a
//!   path is refined where the physics needs it, e.g.
//!   `[{ from = 0.0025, to = 0.1, step = 0.01 }, { to = 0.2, step = 0.0025 }, { to = 1, step = 0.02 }]`.
//! - `reverse` (default true): after the forward branch, retrace its values backwards
//!   (warm-started from the last state).
//! - `reverse_extension`: segments `{ to, steps | step }` that continue the reverse branch below
//!   the forward branch's first value, e.g. into tensile loads with adhesion (default none). The
//!   branch ends early when the surfaces separate (pull-off); that is recorded, not an error.
//! - solver: `method` (any of [`contact::Method::ALL`] by name: `auto`, `polonsky-keer`,
//!   `polonsky-keer-plain` (both hard wall only), `fire`, `nonlinear-cg`), `tol_gap`,
//!   `tol_force`, `max_iter` ([`contact::SolverOptions`]).
//! - `jump_ratio`, `jump_window`: [`analysis::JumpOptions`] of the jump detector;
//!   `loop_tolerance` (default 0.02): area difference between the branches that makes a
//!   hysteresis loop even without a change of topology ([`Loop`]).
//! - `fields_at`: control values (in `unit` for loads) at which the full fields (gap,
//!   displacement, pressure) of the nearest point of each branch are stored (default none: the
//!   artefact stays small); `fields_all = true` stores them at every point.
//! - `refine_jumps` (0 ..= 16, default 0: off), `refine_area` (default 0.02): a step whose
//!   states differ in topology (in contact, full contact, fluid percolating along x, along y) or
//!   in relative contact area by more than `refine_area` is bisected `refine_jumps` times from
//!   the earlier state ([`contact::path::Refinement`]), so its jump is located within
//!   step/2^refine_jumps whatever the minimiser. The planned points are solved as without
//!   refinement; the midpoints are added (`refined = 1`), and the jumps, loop ends and
//!   thresholds are bracketed by them.
//! - `min_zone_spacings` (default 4): warn when the cohesive-zone length ρ²E*/γ is resolved by
//!   fewer grid spacings (jumps are then mesh-dependent); on a strength path at its largest
//!   strength, naming the strength above which the zone is under-resolved.
//!
//! The path is [`contact::path::run`]: every point starts from the previous point's state (a
//! warm start), so metastable branches and hysteresis appear where they exist; the reverse
//! extension and pull-off are handled there. This module parses the parameters, measures the
//! topology of each point, detects the jumps ([`analysis::detect_jumps`]) and the hysteresis
//! loops ([`analysis::hysteresis`]), and writes the artefact.
//!
//! # Artefact
//! - root attributes: `interaction`, `gamma0` / `gamma_r`, `rho`, `control`, `unit`, `p_fc`
//!   (of the grid, E* h0/λ), `unit_scale` (p_fc or 1), `lattice`, `n`, `nx`, `ny`, `dx`,
//!   `cohesive_zone_length` (NaN for the hard wall; on a strength path at its largest
//!   strength), `zone_spacings` (the same in grid spacings), `n_points`,
//!   `n_unconverged`, `lx`, `ly`;
//! - `points/*`, one entry per solved point in path order: `branch` ("loading" / "unloading":
//!   control increasing / decreasing), `step`, `load` (E* h0/λ), `strength`, `contact_area`,
//!   `contact_area_corrected` (perimeter-corrected, [`percolation::contact_area`]),
//!   `mean_gap`, `mean_displacement`, `energy`, `iterations`, `max_violation`,
//!   `force_residual`, `converged` (u8: 0 or 1), `stop_reason` ("" if converged), `wall_s`,
//!   `contact_clusters` (8-connected), `fluid_percolates_x`, `fluid_percolates_y`, `refined`
//!   (u8; 1 for a refinement point, whose `step` is the planned point it precedes);
//! - `jumps/*`, one entry per detected jump (detected on each branch's converged planned points,
//!   then narrowed to the bracket the refinement left between them,
//!   [`contact::path::PathResult::refined_jumps`]):
//!   `branch`, `index` and `index_after` (point indices before and after), `load_before`,
//!   `load_after`, `strength_before`, `strength_after`, `area_before`, `area_after`, `ratio`,
//!   `event` (see [`analysis::hysteresis::classify`]), `detector` (`trend`: [`analysis::detect_jumps`]; `loop`: an
//!   end of a hysteresis loop the trend detector missed, see [`analysis::hysteresis::find_loops`]);
//! - `loops/*`, one entry per hysteresis loop between the branches ([`Loop`]): `x_lo`, `x_hi`
//!   (control values: loads in E* h0/λ or strengths), `max_area_difference`, `x_at_max`;
//! - `ended/*`: `branch`, `load`, `strength`, `message` of each branch that ended early
//!   (pull-off: the surfaces separated);
//! - `thresholds/*` (strength paths only), one entry per threshold the path crosses
//!   ([`analysis::hysteresis::Thresholds`] on the converged points, refinement points included: `coalescence` (γ_p) and
//!   `full_contact` (γ_fc) on the loading branch, `break_up` and `trough_opening` on the
//!   unloading one): `name`, `x_before`, `x_after` (strengths bracketing it), `area_before`,
//!   `area_after`. Figure 3 and its headline numbers read them;
//! - `fields/<branch>_<index>/{gap,displacement,pressure}` if `fields_at` asked for them.
//!
//! The records are declared once in [`crate::sweep_artefact`] (writer and reader); the
//! parameters in [`crate::sweep_params`].
//!
//! Non-converged points are kept and flagged (`converged = 0`, `stop_reason`), listed in the
//! stage's warnings, and left out of jump detection; downstream kinds must not use them silently.

use crate::surface::SurfaceInput;
use crate::sweep_artefact::{self as artefact, Attrs, Sweep};
use crate::sweep_params::{ControlKind, SweepParams};
use analysis::hysteresis::{self, BranchState, Thresholds};
use anyhow::{Result, anyhow};
pub use contact::path::Branch;
use contact::path::{self, Control, PathPoint, PathSpec};
use contact::{Interaction, Solution, SolverOptions};
use orchestrator::{
    InputSpec, Inputs, ParamIssue, ParamSpec, StageContext, StageReport, TypedKind,
};
use serde_json::{Value, json};
use store::ArtefactWriter;

pub use crate::sweep_artefact::{Detector, Ended, JumpRow, Loop, Point, SweepData};

/// The `sweep` stage kind.
pub struct SweepKind;

/// Bump when the artefact's content changes for the same parameters.
pub const CODE_VERSION: u64 = 3;

impl TypedKind for SweepKind {
    type Params = SweepParams;
    /// Lower bound: heights, displacement, pressure and gap on the surface's grid (the solver
    /// holds more: FFT buffers, minimiser state).
    fn memory_estimate(
        &self,
        _params: &orchestrator::Params,
        inputs: &std::collections::BTreeMap<String, Vec<orchestrator::Params>>,
    ) -> Option<u64> {
        let n = inputs.get("surface")?.first()?.i64("n").ok()?;
        Some(4 * crate::surface::field_bytes(n))
    }
    fn name(&self) -> &str {
        "sweep"
    }
    fn code_version(&self) -> u64 {
        CODE_VERSION
    }
    fn doc(&self) -> &str {
        "quasi-static loading/unloading path (or γ path at fixed load) on one surface, with jumps"
    }
    fn params(&self) -> Vec<ParamSpec> {
        crate::sweep_params::specs()
    }
    fn check(&self, params: &SweepParams) -> Result<(), ParamIssue> {
        params.check()
    }
    fn inputs(&self, _params: &SweepParams) -> Vec<InputSpec> {
        vec![InputSpec::one("surface", &["surface"]).doc("the surface to press against")]
    }
    fn cost(&self, params: &SweepParams) -> f64 {
        let n = params.forward().map_or(10, |v| v.len());
        (if params.reverse { 2 * n } else { n }) as f64 * 0.05
    }
    fn run(
        &self,
        ctx: &mut StageContext,
        params: &SweepParams,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        let mut surface = SurfaceInput::read(inputs.one("surface")?)?;
        let setup = Setup::new(params, &surface)?;
        let zone = setup.zone_resolution(ctx, &surface, params.min_zone_spacings);
        let plan = setup.spec.plan(setup.base);
        let keep = fields_to_keep(&setup, &plan, &params.fields_at);

        // the path: every point warm-started from the previous one (contact::path)
        let mut points: Vec<Point> = Vec::new();
        let total = plan.len();
        let result = path::run_with(
            &mut surface.model,
            setup.base,
            &setup.spec,
            &setup.opts,
            topology,
            |pt, sol| -> Result<()> {
                let point = point_of(pt, sol);
                if params.fields_all || (!pt.refined && keep.contains(&pt.step)) {
                    artefact::write_fields(out, &point, points.len(), sol)?;
                }
                let x = setup.control_value(pt.load, pt.strength);
                let what = format!("{} {x:.4}, a = {:.4}", point.branch, point.contact_area);
                ctx.progress((pt.step + 1) as f64 / total as f64, &what);
                points.push(point);
                Ok(())
            },
        )?;
        let ended: Vec<Ended> = result
            .ended
            .iter()
            .map(|e| ended_of(e, surface.p_fc))
            .collect();

        let refined = &result.refined_jumps;
        let mut jumps = trend_jumps(&points, refined, &setup, params)?;
        let loops =
            loops_and_their_ends(&points, refined, &setup, params.loop_tolerance, &mut jumps);
        let n_bad = warn_unconverged(ctx, &points, &ended, surface.p_fc);
        let thresholds = thresholds(&points, &setup);
        let sweep = Sweep {
            points: &points,
            jumps: &jumps,
            loops: &loops,
            ended: &ended,
            thresholds: thresholds.as_ref(),
        };
        let attrs = Attrs {
            params,
            surface: &surface,
            unit_scale: setup.scale,
            zone,
            n_unconverged: n_bad,
        };
        artefact::write(out, &attrs, &sweep)?;
        Ok(report(&sweep, n_bad, surface.p_fc, zone.1))
    }
}

/// What `run` derives from the parameters and the surface.
struct Setup {
    /// The interaction (its strength replaced along a strength path).
    base: Interaction,
    control: ControlKind,
    /// p_fc or 1: loads are given in this unit.
    scale: f64,
    /// The path in absolute units.
    spec: PathSpec,
    opts: SolverOptions,
}

impl Setup {
    fn new(params: &SweepParams, surface: &SurfaceInput) -> Result<Setup> {
        let base = params.interaction();
        base.validate().map_err(|e| anyhow!("{e}"))?;
        let scale = artefact::unit_scale(params.unit, surface.p_fc);
        let fwd = params.forward().map_err(|e| anyhow!("{e}"))?;
        let ext = params.extension(fwd[0]).map_err(|e| anyhow!("{e}"))?;
        let (control, extension) = match params.control {
            ControlKind::Strength => (
                Control::Strength {
                    load: params.load * scale,
                    values: fwd,
                },
                ext,
            ),
            ControlKind::Load => {
                let abs = |v: Vec<f64>| v.into_iter().map(|v| v * scale).collect::<Vec<_>>();
                (Control::Load { values: abs(fwd) }, abs(ext))
            }
        };
        let spec = PathSpec {
            control,
            reverse: params.reverse,
            extension,
            refine: params.refinement(),
        };
        Ok(Setup {
            base,
            control: params.control,
            scale,
            spec,
            opts: params.solver().options(),
        })
    }

    fn strength_path(&self) -> bool {
        self.control == ControlKind::Strength
    }
    /// The control value of a point in the path's unit (loads over `scale`, or the strength).
    fn control_value(&self, load: f64, strength: f64) -> f64 {
        if self.strength_path() {
            strength
        } else {
            load / self.scale
        }
    }

    /// The control value jumps and loops are measured in (absolute loads, or the strength).
    fn x_of(&self, p: &Point) -> f64 {
        if self.strength_path() {
            p.strength
        } else {
            p.load
        }
    }

    /// The cohesive-zone length ρ²E*/γ (at the path's largest strength on a strength path) and
    /// the grid spacings it spans; warns when that is fewer than `min_spacings`.
    fn zone_resolution(
        &self,
        ctx: &mut StageContext,
        surface: &SurfaceInput,
        min_spacings: f64,
    ) -> (Option<f64>, f64) {
        let dx = surface.lx / surface.nx as f64;
        let strongest = match &self.spec.control {
            Control::Strength { values, .. } => {
                let s_max = values
                    .iter()
                    .chain(&self.spec.extension)
                    .copied()
                    .fold(0.0, f64::max);
                path::with_strength(self.base, s_max)
            }
            Control::Load { .. } => self.base,
        };
        let zone = strongest.cohesive_zone_length(1.0);
        let spacings = zone.map_or(f64::INFINITY, |z| z / dx);
        if spacings < min_spacings {
            let (rho, n_exp) = (self.base.range(), surface.n);
            // strengths above this resolve the zone by fewer than `min_spacings` spacings
            let s_limit = rho * rho / (min_spacings * dx);
            let msg = if self.strength_path() {
                format!(
                    "under-resolved cohesive zone: ρ²E*/γ spans fewer than {min_spacings} grid spacings for γ > {s_limit:.4} (dx = {dx:.3e} λ, n = {n_exp}, ρ = {rho}); at the path's largest γ = {:.4} it is {:.3e} λ = {spacings:.2e} spacings; jumps above γ = {s_limit:.4} depend on the mesh (use a finer grid)",
                    path::strength(strongest),
                    zone.unwrap_or(f64::NAN),
                )
            } else {
                format!(
                    "under-resolved cohesive zone: ρ²E*/γ = {:.3e} λ spans {:.2} grid spacings (dx = {:.3e} λ, n = {n_exp}), fewer than {min_spacings}; jump loads and areas depend on the mesh (use a finer grid)",
                    zone.unwrap_or(f64::NAN),
                    spacings,
                    dx
                )
            };
            ctx.warn(msg);
        }
        (zone, spacings)
    }
}

/// Steps whose fields are kept: per branch, the step nearest to each requested control value.
fn fields_to_keep(
    setup: &Setup,
    plan: &[path::PlannedPoint],
    targets: &[f64],
) -> std::collections::BTreeSet<usize> {
    let value = |s: &path::PlannedPoint| setup.control_value(s.load, path::strength(s.interaction));
    let mut keep = std::collections::BTreeSet::new();
    for &target in targets {
        for br in [Branch::Loading, Branch::Unloading] {
            if let Some(k) = (0..plan.len())
                .filter(|&k| plan[k].branch == br)
                .min_by(|&a, &b| {
                    (value(&plan[a]) - target)
                        .abs()
                        .total_cmp(&(value(&plan[b]) - target).abs())
                })
            {
                keep.insert(k);
            }
        }
    }
    keep
}

/// The topology jumps are told by ([`path::run_with`]): in contact, full contact
/// ([`path::contact_topology`]), fluid percolating along x, along y.
fn topology(sol: &Solution) -> u64 {
    let mask = sol.gap.mapv(|g| g == 0.0);
    let dual = percolation::dual_percolation(mask.view());
    path::contact_topology(sol)
        | (u64::from(dual.fluid_percolates(percolation::Axis::X)) << 2)
        | (u64::from(dual.fluid_percolates(percolation::Axis::Y)) << 3)
}

/// A solved point with the contact's topology measured on its gap field.
fn point_of(pt: &PathPoint, sol: &Solution) -> Point {
    let mask = sol.gap.mapv(|g| g == 0.0);
    let dual = percolation::dual_percolation(mask.view());
    let area = percolation::contact_area(mask.view());
    Point {
        branch: pt.branch,
        step: pt.step as i64,
        load: pt.load,
        strength: pt.strength,
        contact_area: pt.contact_area,
        contact_area_corrected: if area.n_contact == 0 {
            0.0
        } else {
            area.corrected
        },
        mean_gap: pt.mean_gap,
        mean_displacement: pt.mean_displacement,
        energy: pt.energy,
        iterations: pt.iterations as i64,
        max_violation: pt.max_violation,
        force_residual: pt.force_residual,
        converged: pt.converged,
        stop_reason: pt
            .stop_reason
            .as_ref()
            .map(|r| r.to_string())
            .unwrap_or_default(),
        wall_s: pt.wall_s,
        contact_clusters: dual.contact_summary.n_clusters as i64,
        fluid_percolates_x: dual.fluid_percolates(percolation::Axis::X),
        fluid_percolates_y: dual.fluid_percolates(percolation::Axis::Y),
        refined: pt.refined,
    }
}

fn ended_of(e: &path::PullOff, p_fc: f64) -> Ended {
    Ended {
        branch: e.branch,
        load: e.load,
        strength: e.strength,
        message: format!(
            "{} branch ended at step {}: the surfaces separated at mean pressure {:.6e} E*h0/λ ({:.5} p_fc; min gap {:.3e} h0): pull-off, no equilibrium under force control beyond it",
            e.branch.name(),
            e.step,
            e.pressure,
            e.pressure / p_fc,
            e.min_gap
        ),
    }
}

/// Indices of the converged points of `branch`, in path order (refinement points included).
fn converged(points: &[Point], branch: Branch) -> Vec<usize> {
    (0..points.len())
        .filter(|&k| points[k].branch == branch && points[k].converged)
        .collect()
}

/// Indices of the converged planned points of `branch` (no refinement points), in path order:
/// what the trend detector and the loop finder compare (the trend needs the planned steps; the
/// loops compare the branches at the planned values).
fn planned(points: &[Point], branch: Branch) -> Vec<usize> {
    (0..points.len())
        .filter(|&k| points[k].branch == branch && points[k].converged && !points[k].refined)
        .collect()
}

/// The jump between the planned points `a` < `b` narrowed to the bracket the refinement left
/// between them ([`path::PathResult::refined_jumps`]); (a, b) if it left none.
fn narrowed(refined: &[path::RefinedJump], a: usize, b: usize) -> (usize, usize) {
    refined
        .iter()
        .find(|j| a <= j.before && j.after <= b)
        .map_or((a, b), |j| (j.before, j.after))
}

/// A jump between points `a` and `b` (`ratio` NaN for a loop end).
fn jump_row(points: &[Point], a: usize, b: usize, ratio: f64, detector: Detector) -> JumpRow {
    let (pa, pb) = (&points[a], &points[b]);
    JumpRow {
        branch: pa.branch,
        index: a,
        index_after: b,
        load_before: pa.load,
        load_after: pb.load,
        strength_before: pa.strength,
        strength_after: pb.strength,
        area_before: pa.contact_area,
        area_after: pb.contact_area,
        ratio,
        event: hysteresis::classify(pa.contact_area, pb.contact_area, pa.fluid(), pb.fluid())
            .into(),
        detector,
    }
}

/// Jumps against the neighbours' trend ([`analysis::detect_jumps`]), per branch, on converged
/// planned points, each narrowed to its refined bracket.
fn trend_jumps(
    points: &[Point],
    refined: &[path::RefinedJump],
    setup: &Setup,
    params: &SweepParams,
) -> Result<Vec<JumpRow>> {
    let jopts = analysis::JumpOptions {
        ratio: params.jump_ratio,
        window: params.jump_window,
        ..Default::default()
    };
    let mut jumps = Vec::new();
    for br in [Branch::Loading, Branch::Unloading] {
        let idx = planned(points, br);
        let x: Vec<f64> = idx.iter().map(|&k| setup.x_of(&points[k])).collect();
        let y: Vec<f64> = idx.iter().map(|&k| points[k].contact_area).collect();
        let found = analysis::detect_jumps(&x, &y, &jopts)
            .map_err(|e| anyhow!("jump detection on the {br} branch: {e}"))?;
        for j in found {
            let (a, b) = narrowed(refined, idx[j.index], idx[j.index + 1]);
            jumps.push(jump_row(points, a, b, j.ratio, Detector::Trend));
        }
    }
    Ok(jumps)
}

/// The hysteresis loops between the branches ([`hysteresis::find_loops`] on the converged
/// points); the loops' ends the trend detector missed are added to `jumps` (`detector =
/// "loop"`), which end sorted by branch (loading first) and index.
fn loops_and_their_ends(
    points: &[Point],
    refined: &[path::RefinedJump],
    setup: &Setup,
    tolerance: f64,
    jumps: &mut Vec<JumpRow>,
) -> Vec<Loop> {
    let (up, down) = (
        planned(points, Branch::Loading),
        planned(points, Branch::Unloading),
    );
    let (loops, ends) = hysteresis::find_loops(
        &states(points, setup, &up),
        &states(points, setup, &down),
        tolerance,
    );
    for end in ends {
        let idx = if end.forward { &up } else { &down };
        let (a, b) = narrowed(refined, idx[end.before], idx[end.after]);
        if !jumps
            .iter()
            .any(|j| j.branch == points[a].branch && j.index == a)
        {
            jumps.push(jump_row(points, a, b, f64::NAN, Detector::Loop));
        }
    }
    jumps.sort_by_key(|j| (j.branch != Branch::Loading, j.index));
    loops
}

/// The points `idx` as the loop and threshold finders see them.
fn states(points: &[Point], setup: &Setup, idx: &[usize]) -> Vec<BranchState> {
    idx.iter()
        .map(|&k| BranchState {
            x: setup.x_of(&points[k]),
            area: points[k].contact_area,
            fluid: points[k].fluid(),
        })
        .collect()
}

/// A strength path's topological thresholds ([`Thresholds::of`] on the converged points: γ_p,
/// γ_fc, break-up, trough opening); `None` on a load path.
fn thresholds(points: &[Point], setup: &Setup) -> Option<Thresholds> {
    setup.strength_path().then(|| {
        let of = |b: Branch| states(points, setup, &converged(points, b));
        Thresholds::of(&of(Branch::Loading), &of(Branch::Unloading))
    })
}

/// Warns about non-converged points and a forward branch that ended early; returns the number
/// of non-converged points.
fn warn_unconverged(ctx: &mut StageContext, points: &[Point], ended: &[Ended], p_fc: f64) -> usize {
    let bad: Vec<&Point> = points.iter().filter(|p| !p.converged).collect();
    if !bad.is_empty() {
        let list: Vec<String> = bad
            .iter()
            .take(10)
            .map(|p| {
                format!(
                    "step {} ({}, load {:.5} p_fc, strength {}): {} iterations, force residual {:.2e}, violation {:.2e}: {}",
                    p.step,
                    p.branch,
                    p.load / p_fc,
                    p.strength,
                    p.iterations,
                    p.force_residual,
                    p.max_violation,
                    p.stop_reason
                )
            })
            .collect();
        ctx.warn(format!(
            "{} of {} points did not converge (flagged converged = 0, excluded from jump detection){}: {}",
            bad.len(),
            points.len(),
            if bad.len() > 10 { "; the first 10" } else { "" },
            list.join("; ")
        ));
    }
    for e in ended.iter().filter(|e| e.branch == Branch::Loading) {
        ctx.warn(format!("the forward branch ended early: {}", e.message));
    }
    bad.len()
}

fn report(s: &Sweep, n_bad: usize, p_fc: f64, spacings: f64) -> StageReport {
    let points = s.points;
    let iters: Vec<i64> = points.iter().map(|p| p.iterations).collect();
    StageReport::with_stats(json!({
        "points": points.len(),
        "unconverged": n_bad,
        "iterations_total": iters.iter().sum::<i64>(),
        "iterations_max": iters.iter().copied().max().unwrap_or(0),
        "force_residual_max": points.iter().map(|p| p.force_residual).fold(0.0, f64::max),
        "violation_max": points.iter().map(|p| p.max_violation).fold(0.0, f64::max),
        "solve_wall_s": points.iter().map(|p| p.wall_s).sum::<f64>(),
        "loops": s.loops.iter().map(|l| json!({
            "x": [l.x.0, l.x.1],
            "max_area_difference": l.max_area_difference,
        })).collect::<Vec<_>>(),
        "jumps": s.jumps.iter().map(|j| json!({
            "branch": j.branch.name(), "event": j.event, "detector": j.detector.to_string(),
            "load_over_p_fc": [j.load_before / p_fc, j.load_after / p_fc],
            "area": [j.area_before, j.area_after],
        })).collect::<Vec<_>>(),
        "ended": s.ended.iter().map(|e| e.message.clone()).collect::<Vec<_>>(),
        "zone_spacings": if spacings.is_finite() { json!(spacings) } else { Value::Null },
    }))
}
