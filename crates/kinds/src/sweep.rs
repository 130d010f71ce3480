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
//!   `contact_clusters` (8-connected), `fluid_percolates_x`, `fluid_percolates_y` (u8);
//! - `jumps/*`, one entry per detected jump (detected on each branch's converged points):
//!   `branch`, `index` and `index_after` (point indices before and after), `load_before`,
//!   `load_after`, `strength_before`, `strength_after`, `area_before`, `area_after`, `ratio`,
//!   `event` (see [`analysis::hysteresis::classify`]), `detector` (`trend`: [`analysis::detect_jumps`]; `loop`: an
//!   end of a hysteresis loop the trend detector missed, see [`analysis::hysteresis::find_loops`]);
//! - `loops/*`, one entry per hysteresis loop between the branches ([`Loop`]): `x_lo`, `x_hi`
//!   (control values: loads in E* h0/λ or strengths), `max_area_difference`, `x_at_max`;
//! - `ended/*`: `branch`, `load`, `strength`, `message` of each branch that ended early
//!   (pull-off: the surfaces separated);
//! - `fields/<branch>_<index>/{gap,displacement,pressure}` if `fields_at` asked for them.
//!
//! Non-converged points are kept and flagged (`converged = 0`, `stop_reason`), listed in the
//! stage's warnings, and left out of jump detection; downstream kinds must not use them silently.

use analysis::hysteresis::{self, BranchState};
use anyhow::{Context, Result, anyhow, bail};
use contact::path::{self, Branch, Control, PathPoint, PathSpec};
use contact::{Interaction, Method, Solution, SolverOptions};
use orchestrator::{
    InputSpec, Inputs, ParamIssue, ParamSpec, ParamType, Params, StageContext, StageKind,
    StageReport,
};
use serde_json::{Value, json};
use store::{ArtefactReader, ArtefactWriter};

/// The `sweep` stage kind.
pub struct SweepKind;

/// Bump when the artefact's content changes for the same parameters.
pub const CODE_VERSION: u64 = 2;

/// Largest number of points a path may have.
pub const MAX_POINTS: usize = 100_000;

/// One segment of a path: values from `from` (the previous end if `None`) to `to` in `steps`
/// equal steps.
#[derive(Clone, Debug, PartialEq)]
pub struct Segment {
    /// Start (only the first segment of a forward path gives it).
    pub from: Option<f64>,
    /// End (included).
    pub to: f64,
    /// Number of equal steps.
    pub steps: usize,
}

fn issue(key: &str, msg: impl Into<String>) -> ParamIssue {
    ParamIssue::new(key, msg)
}

/// Parses a list of segments. `forward`: the first segment must give `from` and values
/// increase; otherwise (`reverse_extension`) `from` is not allowed and values decrease from
/// `start`.
pub fn parse_segments(
    key: &str,
    v: &Value,
    forward: bool,
    start: Option<f64>,
) -> Result<Vec<Segment>, ParamIssue> {
    let items = v.as_array().ok_or_else(|| {
        issue(
            key,
            "expected an array of segments like { from = 0.01, to = 0.5, steps = 20 } or { to = 1.0, step = 0.02 }",
        )
    })?;
    if forward && items.is_empty() {
        return Err(issue(key, "the path needs at least one segment"));
    }
    let mut segs = Vec::new();
    let mut prev_end = start;
    let mut total = 0usize;
    for (i, item) in items.iter().enumerate() {
        let at = |m: String| issue(key, format!("segment {i}: {m}"));
        let t = item.as_object().ok_or_else(|| {
            at(format!(
                "expected a table like {{ to = 0.5, steps = 20 }}, found {}",
                orchestrator::schema::describe(item)
            ))
        })?;
        for k in t.keys() {
            if !["from", "to", "steps", "step"].contains(&k.as_str()) {
                return Err(at(format!(
                    "unknown key `{k}`; allowed: from, to, steps, step"
                )));
            }
        }
        let num = |k: &str| -> Result<Option<f64>, ParamIssue> {
            match t.get(k) {
                None => Ok(None),
                Some(x) => match x.as_f64() {
                    Some(f) if f.is_finite() => Ok(Some(f)),
                    _ => Err(at(format!(
                        "`{k}` must be a finite number, found {}",
                        orchestrator::schema::describe(x)
                    ))),
                },
            }
        };
        let from = num("from")?;
        let to = num("to")?.ok_or_else(|| at("`to` is required".into()))?;
        let from_eff = match (from, prev_end) {
            (Some(f), None) => f,
            (None, Some(p)) => p,
            (Some(f), Some(p)) => {
                if !forward {
                    return Err(at(format!(
                        "`from` is not allowed here: the extension starts where the forward path starts ({p})"
                    )));
                }
                if (f - p).abs() > 1e-12 * (1.0 + p.abs()) {
                    return Err(at(format!(
                        "`from` = {f} but the previous segment ends at {p}; omit `from` after the first segment"
                    )));
                }
                p
            }
            (None, None) => return Err(at("the first segment needs `from`".into())),
        };
        let span = to - from_eff;
        if forward && span <= 0.0 {
            return Err(at(format!(
                "`to` = {to} must be greater than the segment's start {from_eff} (a path increases)"
            )));
        }
        if !forward && span >= 0.0 {
            return Err(at(format!(
                "`to` = {to} must be below the segment's start {from_eff} (the extension continues downwards)"
            )));
        }
        let steps = match (t.get("steps"), num("step")?) {
            (Some(_), Some(_)) => return Err(at("give `steps` or `step`, not both".into())),
            (None, None) => return Err(at("give `steps` (a count) or `step` (a size)".into())),
            (Some(s), None) => match s.as_i64() {
                Some(s) if s >= 1 => s as usize,
                _ => {
                    return Err(at(format!(
                        "`steps` must be an integer ≥ 1, found {}",
                        orchestrator::schema::describe(s)
                    )));
                }
            },
            (None, Some(step)) => {
                if step <= 0.0 {
                    return Err(at(format!("`step` must be > 0, found {step:?}")));
                }
                let n = (span.abs() / step - 1e-9).ceil();
                if n > MAX_POINTS as f64 {
                    return Err(at(format!(
                        "`step` = {step:?} gives {n:.3e} points; at most {MAX_POINTS} are allowed"
                    )));
                }
                (n as usize).max(1)
            }
        };
        total += steps;
        if total > MAX_POINTS {
            return Err(at(format!("the path has more than {MAX_POINTS} points")));
        }
        segs.push(Segment {
            from: if i == 0 && forward {
                Some(from_eff)
            } else {
                None
            },
            to,
            steps,
        });
        prev_end = Some(to);
    }
    Ok(segs)
}

/// The values of a list of segments starting at `start` (the first segment's `from` if it has
/// one); `include_start` adds the start itself.
pub fn expand(segs: &[Segment], start: f64, include_start: bool) -> Vec<f64> {
    let mut out = Vec::new();
    let mut a = segs.first().and_then(|s| s.from).unwrap_or(start);
    if include_start {
        out.push(a);
    }
    for s in segs {
        for k in 1..=s.steps {
            out.push(if k == s.steps {
                s.to
            } else {
                a + (s.to - a) * k as f64 / s.steps as f64
            });
        }
        a = s.to;
    }
    out
}

/// The forward values of a sweep's `path` (in its unit), checked.
fn forward_values(params: &Params) -> Result<Vec<f64>, ParamIssue> {
    let segs = parse_segments(
        "path",
        params
            .get("path")
            .map_err(|e| issue("path", e.to_string()))?,
        true,
        None,
    )?;
    Ok(expand(&segs, 0.0, true))
}

/// The reverse extension's values (in the path's unit), below the forward branch's start.
fn extension_values(params: &Params, start: f64) -> Result<Vec<f64>, ParamIssue> {
    let v = params
        .get("reverse_extension")
        .map_err(|e| issue("reverse_extension", e.to_string()))?;
    let segs = parse_segments("reverse_extension", v, false, Some(start))?;
    Ok(expand(&segs, start, false))
}

fn interaction_of(params: &Params) -> Result<Interaction> {
    let rho = params.f64("rho")?;
    Ok(match params.str("interaction")? {
        "hardwall" => Interaction::HardWall,
        "adhesion" => Interaction::Adhesion {
            gamma0: params.f64("gamma0")?,
            rho,
        },
        "repulsion" => Interaction::Repulsion {
            gamma_r: params.f64("gamma_r")?,
            rho,
        },
        other => bail!("interaction `{other}`: allowed hardwall, adhesion, repulsion"),
    })
}

/// One solved point (what `points/*` holds).
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    /// "loading" (control increasing) or "unloading".
    pub branch: String,
    /// Index in the planned path (forward and reverse numbered continuously).
    pub step: i64,
    /// Mean pressure (E* h0/λ).
    pub load: f64,
    /// γ0 or γr (0 for the hard wall).
    pub strength: f64,
    /// Relative contact area (fraction of nodes with g = 0).
    pub contact_area: f64,
    /// Perimeter-corrected contact area.
    pub contact_area_corrected: f64,
    /// Mean gap (h0).
    pub mean_gap: f64,
    /// Mean of u (h0).
    pub mean_displacement: f64,
    /// Energy per area.
    pub energy: f64,
    /// Minimiser iterations.
    pub iterations: i64,
    /// Final constraint violation.
    pub max_violation: f64,
    /// Final force residual.
    pub force_residual: f64,
    /// Met the tolerance.
    pub converged: bool,
    /// Why it did not converge ("" if it did).
    pub stop_reason: String,
    /// Wall time of the solve (s).
    pub wall_s: f64,
    /// Contact clusters (8-connected).
    pub contact_clusters: i64,
    /// Fluid (4-connected) wraps along x.
    pub fluid_percolates_x: bool,
    /// Fluid wraps along y.
    pub fluid_percolates_y: bool,
}

/// One detected jump (what `jumps/*` holds).
#[derive(Clone, Debug, PartialEq)]
pub struct JumpRow {
    /// Branch name.
    pub branch: String,
    /// Point index before the jump.
    pub index: usize,
    /// Point index after the jump (the next converged point of the branch).
    pub index_after: usize,
    /// Loads before and after (E* h0/λ).
    pub load: (f64, f64),
    /// Strengths before and after.
    pub strength: (f64, f64),
    /// Areas before and after.
    pub area: (f64, f64),
    /// Jump size over the neighbours' trend (NaN for a loop end the trend detector missed).
    pub ratio: f64,
    /// [`analysis::hysteresis::classify`].
    pub event: String,
    /// Which detector found it: `trend` ([`analysis::detect_jumps`]) or `loop` (an end of a
    /// hysteresis loop, see [`Loop`]).
    pub detector: String,
}

/// A hysteresis loop between the branches (what `loops/*` holds): see [`analysis::hysteresis`];
/// `x` in control values (loads in E* h0/λ, or strengths).
pub use analysis::hysteresis::Loop;

/// A branch that ended early.
#[derive(Clone, Debug, PartialEq)]
pub struct Ended {
    /// Branch name.
    pub branch: String,
    /// The load at which no equilibrium was found (E* h0/λ).
    pub load: f64,
    /// The strength there.
    pub strength: f64,
    /// Why.
    pub message: String,
}

/// A sweep artefact, read back (for the figure and table kinds).
#[derive(Clone, Debug, PartialEq)]
pub struct SweepData {
    /// hardwall, adhesion or repulsion.
    pub interaction: String,
    /// load or strength.
    pub control: String,
    /// Full-contact pressure of the grid (E* h0/λ).
    pub p_fc: f64,
    /// Surface model.
    pub lattice: String,
    /// Grid exponent.
    pub n: i64,
    /// Points in path order.
    pub points: Vec<Point>,
    /// Detected jumps.
    pub jumps: Vec<JumpRow>,
    /// Hysteresis loops between the branches.
    pub loops: Vec<Loop>,
    /// Branches that ended early.
    pub ended: Vec<Ended>,
}

impl SweepData {
    /// Reads a `sweep` artefact.
    pub fn read(r: &ArtefactReader) -> Result<Self> {
        let ctx = || format!("reading sweep artefact `{}`", r.path().display());
        (|| -> Result<Self> {
            let f = |k: &str| r.read_f64_1d(&format!("points/{k}"));
            let i = |k: &str| r.read_i64_1d(&format!("points/{k}"));
            let b = |k: &str| -> Result<Vec<bool>> {
                Ok(r.read_u8_1d(&format!("points/{k}"))?
                    .into_iter()
                    .map(|x| x != 0)
                    .collect())
            };
            let branch = r.read_strings("points/branch")?;
            let (step, load, strength) = (i("step")?, f("load")?, f("strength")?);
            let (area, area_c, gap) = (
                f("contact_area")?,
                f("contact_area_corrected")?,
                f("mean_gap")?,
            );
            let (disp, energy, iters) = (f("mean_displacement")?, f("energy")?, i("iterations")?);
            let (viol, force, conv) = (f("max_violation")?, f("force_residual")?, b("converged")?);
            let (reason, wall) = (r.read_strings("points/stop_reason")?, f("wall_s")?);
            let (clusters, fx, fy) = (
                i("contact_clusters")?,
                b("fluid_percolates_x")?,
                b("fluid_percolates_y")?,
            );
            let n = branch.len();
            for (name, len) in [
                ("step", step.len()),
                ("load", load.len()),
                ("contact_area", area.len()),
                ("converged", conv.len()),
                ("fluid_percolates_y", fy.len()),
            ] {
                if len != n {
                    bail!("points/{name} has {len} entries, points/branch has {n}");
                }
            }
            let points = (0..n)
                .map(|k| Point {
                    branch: branch[k].clone(),
                    step: step[k],
                    load: load[k],
                    strength: strength[k],
                    contact_area: area[k],
                    contact_area_corrected: area_c[k],
                    mean_gap: gap[k],
                    mean_displacement: disp[k],
                    energy: energy[k],
                    iterations: iters[k],
                    max_violation: viol[k],
                    force_residual: force[k],
                    converged: conv[k],
                    stop_reason: reason[k].clone(),
                    wall_s: wall[k],
                    contact_clusters: clusters[k],
                    fluid_percolates_x: fx[k],
                    fluid_percolates_y: fy[k],
                })
                .collect();
            let jf = |k: &str| r.read_f64_1d(&format!("jumps/{k}"));
            let jb = r.read_strings("jumps/branch")?;
            let (ji, ja) = (
                r.read_i64_1d("jumps/index")?,
                r.read_i64_1d("jumps/index_after")?,
            );
            let (lb, la) = (jf("load_before")?, jf("load_after")?);
            let (sb, sa) = (jf("strength_before")?, jf("strength_after")?);
            let (ab, aa, ratio) = (jf("area_before")?, jf("area_after")?, jf("ratio")?);
            let ev = r.read_strings("jumps/event")?;
            let det = r.read_strings("jumps/detector")?;
            let jumps = (0..jb.len())
                .map(|k| JumpRow {
                    branch: jb[k].clone(),
                    index: ji[k] as usize,
                    index_after: ja[k] as usize,
                    load: (lb[k], la[k]),
                    strength: (sb[k], sa[k]),
                    area: (ab[k], aa[k]),
                    ratio: ratio[k],
                    event: ev[k].clone(),
                    detector: det[k].clone(),
                })
                .collect();
            let lf = |k: &str| r.read_f64_1d(&format!("loops/{k}"));
            let (lo, hi, dmax, xmax) = (
                lf("x_lo")?,
                lf("x_hi")?,
                lf("max_area_difference")?,
                lf("x_at_max")?,
            );
            let loops = (0..lo.len())
                .map(|k| Loop {
                    x: (lo[k], hi[k]),
                    max_area_difference: dmax[k],
                    x_at_max: xmax[k],
                })
                .collect();
            let eb = r.read_strings("ended/branch")?;
            let (el, es) = (
                r.read_f64_1d("ended/load")?,
                r.read_f64_1d("ended/strength")?,
            );
            let em = r.read_strings("ended/message")?;
            let ended = (0..eb.len())
                .map(|k| Ended {
                    branch: eb[k].clone(),
                    load: el[k],
                    strength: es[k],
                    message: em[k].clone(),
                })
                .collect();
            Ok(SweepData {
                interaction: r.attr_str("interaction")?,
                control: r.attr_str("control")?,
                p_fc: r.attr_f64("p_fc")?,
                lattice: r.attr_str("lattice")?,
                n: r.attr_i64("n")?,
                points,
                jumps,
                loops,
                ended,
            })
        })()
        .with_context(ctx)
    }

    /// Indices of the points of `branch`, in path order.
    pub fn branch_indices(&self, branch: &str) -> Vec<usize> {
        (0..self.points.len())
            .filter(|&k| self.points[k].branch == branch)
            .collect()
    }
}

impl StageKind for SweepKind {
    /// Lower bound: heights, displacement, pressure and gap on the surface's grid (the solver
    /// holds more: FFT buffers, minimiser state).
    fn memory_estimate(
        &self,
        _params: &Params,
        inputs: &std::collections::BTreeMap<String, Vec<Params>>,
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
        let empty_array = || ParamType::Array {
            elem: Box::new(ParamType::float()),
            min_len: 0,
            max_len: None,
        };
        vec![
            ParamSpec::new(
                "interaction",
                ParamType::one_of(&["hardwall", "adhesion", "repulsion"]),
            )
            .doc("interaction on top of the hard wall"),
            ParamSpec::new("gamma0", ParamType::non_negative())
                .default(0.2)
                .doc("adhesion: surface energy γ0 (E* h0²/λ)"),
            ParamSpec::new("gamma_r", ParamType::non_negative())
                .default(0.2)
                .doc("repulsion: barrier energy γr (E* h0²/λ)"),
            ParamSpec::new("rho", ParamType::positive())
                .default(0.04)
                .doc("interaction range ρ (h0)"),
            ParamSpec::new("control", ParamType::one_of(&["load", "strength"]))
                .default("load")
                .doc("what the path varies: the mean pressure, or γ0/γr at fixed `load`"),
            ParamSpec::new("unit", ParamType::one_of(&["p_fc", "absolute"]))
                .default("p_fc")
                .doc("unit of loads: the grid's full-contact pressure, or E* h0/λ"),
            ParamSpec::new("path", ParamType::Any)
                .doc("forward branch: segments { from, to, steps | step }"),
            ParamSpec::new("reverse", ParamType::Bool)
                .default(true)
                .doc("retrace the path backwards after the forward branch"),
            ParamSpec::new("reverse_extension", ParamType::Any)
                .default(json!([]))
                .doc("segments { to, steps | step } continuing the reverse branch below the path's start"),
            ParamSpec::new("load", ParamType::float())
                .default(0.0)
                .doc("strength control: the fixed mean pressure (in `unit`)"),
            ParamSpec::new("method", ParamType::one_of(&Method::ALL.map(Method::name)))
            .default("auto")
            .doc("minimiser (auto: Polonsky–Keer for the hard wall; nonlinear CG for adhesion and repulsion where the grid resolves the cohesive zone, FIRE where it does not)"),
            ParamSpec::new("tol_gap", ParamType::positive())
                .default(1e-10)
                .doc("constraint-violation tolerance (h0)"),
            ParamSpec::new("tol_force", ParamType::positive())
                .default(1e-8)
                .doc("force-residual tolerance (E* h0/λ)"),
            ParamSpec::new("max_iter", ParamType::int_range(1, 100_000_000))
                .default(200_000)
                .doc("iteration cap per point"),
            ParamSpec::new(
                "jump_ratio",
                ParamType::Float {
                    min: Some(1.0),
                    min_exclusive: true,
                    max: None,
                    max_exclusive: false,
                },
            )
            .default(5.0)
            .doc("a jump is this many times larger than its neighbours' trend"),
            ParamSpec::new("jump_window", ParamType::int_range(1, 20))
                .default(2)
                .doc("neighbour steps on each side for the jump detector"),
            ParamSpec::new("loop_tolerance", ParamType::non_negative())
                .default(0.02)
                .doc("branches whose areas differ by more than this (or in topology) form a hysteresis loop"),
            ParamSpec::new("fields_at", empty_array())
                .default(json!([]))
                .doc("control values at which the full fields of each branch are stored"),
            ParamSpec::new("fields_all", ParamType::Bool)
                .default(false)
                .doc("store the fields of every point (what a flux-against-load curve needs)"),
            ParamSpec::new("min_zone_spacings", ParamType::non_negative())
                .default(4.0)
                .doc("warn when ρ²E*/γ spans fewer grid spacings"),
        ]
    }
    fn check(&self, params: &Params) -> Result<(), ParamIssue> {
        let fwd = forward_values(params)?;
        let ext = extension_values(params, fwd[0])?;
        let control = params.str("control").unwrap_or("load");
        let inter = params.str("interaction").unwrap_or("hardwall");
        if control == "strength" {
            if inter == "hardwall" {
                return Err(issue(
                    "control",
                    "\"strength\" needs interaction \"adhesion\" or \"repulsion\" (the hard wall has no strength)",
                ));
            }
            if let Some(v) = fwd.iter().chain(&ext).find(|&&v| v < 0.0) {
                return Err(issue("path", format!("strengths must be ≥ 0, found {v}")));
            }
            let load = params.f64("load").unwrap_or(0.0);
            if load <= 0.0 && inter != "adhesion" {
                return Err(issue(
                    "load",
                    format!(
                        "{load}: without adhesion the fixed load must be > 0 (no equilibrium otherwise)"
                    ),
                ));
            }
        } else if inter != "adhesion"
            && let Some(v) = fwd.iter().chain(&ext).find(|&&v| v <= 0.0)
        {
            return Err(issue(
                if fwd.contains(v) {
                    "path"
                } else {
                    "reverse_extension"
                },
                format!(
                    "load {v}: without adhesion every load must be > 0 (under force control a non-positive load has no equilibrium)"
                ),
            ));
        }
        if !params.bool("reverse").unwrap_or(true) && !ext.is_empty() {
            return Err(issue(
                "reverse_extension",
                "needs `reverse = true` (it continues the reverse branch)",
            ));
        }
        if let Some(m) = params
            .str("method")
            .ok()
            .and_then(|m| m.parse::<Method>().ok())
            && m.hard_wall_only()
            && inter != "hardwall"
        {
            return Err(issue(
                "method",
                format!(
                    "\"{m}\" solves the hard wall only; use \"fire\", \"nonlinear-cg\" or \"auto\""
                ),
            ));
        }
        Ok(())
    }
    fn inputs(&self, _params: &Params) -> Vec<InputSpec> {
        vec![InputSpec::one("surface", &["surface"]).doc("the surface to press against")]
    }
    fn cost(&self, params: &Params) -> f64 {
        let n = forward_values(params).map_or(10, |v| v.len());
        let reverse = params.bool("reverse").unwrap_or(true);
        (if reverse { 2 * n } else { n }) as f64 * 0.05
    }
    fn run(
        &self,
        ctx: &mut StageContext,
        params: &Params,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        let mut surface = crate::surface::SurfaceInput::read(inputs.one("surface")?)?;
        let setup = Setup::parse(params, &surface)?;
        let zone = setup.zone_resolution(ctx, &surface, params.f64("min_zone_spacings")?);
        let plan = setup.spec.plan(setup.base);
        let keep = fields_to_keep(&setup, &plan, &params.f64_array("fields_at")?);
        let fields_all = params.bool("fields_all")?;

        // the path: every point warm-started from the previous one (contact::path)
        let mut points: Vec<Point> = Vec::new();
        let total = plan.len();
        let result = contact::path::run(
            &mut surface.model,
            setup.base,
            &setup.spec,
            &setup.opts,
            |pt, sol| -> Result<()> {
                let point = point_of(pt, sol);
                if fields_all || keep.contains(&pt.step) {
                    write_fields(out, &point, points.len(), sol)?;
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

        let mut jumps = trend_jumps(&points, &setup, params)?;
        let loops =
            loops_and_their_ends(&points, &setup, params.f64("loop_tolerance")?, &mut jumps);
        let n_bad = warn_unconverged(ctx, &points, &ended, surface.p_fc);
        let sweep = Sweep {
            points: &points,
            jumps: &jumps,
            loops: &loops,
            ended: &ended,
        };
        write_artefact(out, &setup, &surface, zone, n_bad, &sweep)?;
        Ok(report(&sweep, n_bad, surface.p_fc, zone.1))
    }
}

/// What `run` reads from the parameters and the surface.
struct Setup {
    /// The interaction (its strength replaced along a strength path).
    base: Interaction,
    control: String,
    unit: String,
    /// p_fc or 1: loads are given in this unit.
    scale: f64,
    /// The path in absolute units.
    spec: PathSpec,
    opts: SolverOptions,
}

impl Setup {
    fn parse(params: &Params, surface: &crate::surface::SurfaceInput) -> Result<Setup> {
        let base = interaction_of(params)?;
        base.validate().map_err(|e| anyhow!("{e}"))?;
        let control = params.str("control")?.to_string();
        let unit = params.str("unit")?.to_string();
        let scale = if unit == "p_fc" { surface.p_fc } else { 1.0 };
        let fwd = forward_values(params).map_err(|e| anyhow!("{e}"))?;
        let ext = extension_values(params, fwd[0]).map_err(|e| anyhow!("{e}"))?;
        let (control_spec, extension) = if control == "strength" {
            let load = params.f64("load").unwrap_or(0.0) * scale;
            (Control::Strength { load, values: fwd }, ext)
        } else {
            let abs = |v: Vec<f64>| v.into_iter().map(|v| v * scale).collect::<Vec<_>>();
            (Control::Load { values: abs(fwd) }, abs(ext))
        };
        let spec = PathSpec {
            control: control_spec,
            reverse: params.bool("reverse")?,
            extension,
        };
        let opts = SolverOptions {
            tol_gap: params.f64("tol_gap")?,
            tol_force: params.f64("tol_force")?,
            max_iter: params.i64("max_iter")? as usize,
            method: params
                .str("method")?
                .parse::<Method>()
                .map_err(|e| anyhow!("{e}"))?,
            trace: false,
        };
        Ok(Setup {
            base,
            control,
            unit,
            scale,
            spec,
            opts,
        })
    }

    fn strength_path(&self) -> bool {
        self.control == "strength"
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
        surface: &crate::surface::SurfaceInput,
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

/// A solved point with the contact's topology measured on its gap field.
fn point_of(pt: &PathPoint, sol: &Solution) -> Point {
    let mask = sol.gap.mapv(|g| g == 0.0);
    let dual = percolation::dual_percolation(mask.view());
    let area = percolation::contact_area(mask.view());
    Point {
        branch: pt.branch.name().into(),
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
    }
}

/// `fields/<branch>_<index>/{gap,displacement,pressure}` of the `index`-th solved point.
fn write_fields(
    out: &mut ArtefactWriter,
    point: &Point,
    index: usize,
    sol: &Solution,
) -> Result<()> {
    let g = format!("fields/{}_{index}", point.branch);
    out.write_f64_2d(&format!("{g}/gap"), sol.gap.view())?;
    out.write_f64_2d(&format!("{g}/displacement"), sol.displacement.view())?;
    out.write_f64_2d(&format!("{g}/pressure"), sol.pressure.view())?;
    out.set_attr_at(&g, "load", point.load)?;
    out.set_attr_at(&g, "strength", point.strength)?;
    out.set_attr_at(&g, "contact_area", point.contact_area)?;
    Ok(())
}

fn ended_of(e: &path::PullOff, p_fc: f64) -> Ended {
    Ended {
        branch: e.branch.name().into(),
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

fn fluid(p: &Point) -> bool {
    p.fluid_percolates_x || p.fluid_percolates_y
}

/// Indices of the converged points of `branch`, in path order.
fn converged(points: &[Point], branch: &str) -> Vec<usize> {
    (0..points.len())
        .filter(|&k| points[k].branch == branch && points[k].converged)
        .collect()
}

/// A jump between points `a` and `b` (`ratio` NaN for a loop end).
fn jump_row(points: &[Point], a: usize, b: usize, ratio: f64, detector: &str) -> JumpRow {
    let (pa, pb) = (&points[a], &points[b]);
    JumpRow {
        branch: pa.branch.clone(),
        index: a,
        index_after: b,
        load: (pa.load, pb.load),
        strength: (pa.strength, pb.strength),
        area: (pa.contact_area, pb.contact_area),
        ratio,
        event: hysteresis::classify(pa.contact_area, pb.contact_area, fluid(pa), fluid(pb)).into(),
        detector: detector.into(),
    }
}

/// Jumps against the neighbours' trend ([`analysis::detect_jumps`]), per branch, on converged
/// points.
fn trend_jumps(points: &[Point], setup: &Setup, params: &Params) -> Result<Vec<JumpRow>> {
    let jopts = analysis::JumpOptions {
        ratio: params.f64("jump_ratio")?,
        window: params.i64("jump_window")? as usize,
        ..Default::default()
    };
    let mut jumps = Vec::new();
    for br in ["loading", "unloading"] {
        let idx = converged(points, br);
        let x: Vec<f64> = idx.iter().map(|&k| setup.x_of(&points[k])).collect();
        let y: Vec<f64> = idx.iter().map(|&k| points[k].contact_area).collect();
        let found = analysis::detect_jumps(&x, &y, &jopts)
            .map_err(|e| anyhow!("jump detection on the {br} branch: {e}"))?;
        for j in found {
            jumps.push(jump_row(
                points,
                idx[j.index],
                idx[j.index + 1],
                j.ratio,
                "trend",
            ));
        }
    }
    Ok(jumps)
}

/// The hysteresis loops between the branches ([`hysteresis::find_loops`] on the converged
/// points); the loops' ends the trend detector missed are added to `jumps` (`detector =
/// "loop"`), which end sorted by branch (loading first) and index.
fn loops_and_their_ends(
    points: &[Point],
    setup: &Setup,
    tolerance: f64,
    jumps: &mut Vec<JumpRow>,
) -> Vec<Loop> {
    let (up, down) = (converged(points, "loading"), converged(points, "unloading"));
    let states = |idx: &[usize]| -> Vec<BranchState> {
        idx.iter()
            .map(|&k| BranchState {
                x: setup.x_of(&points[k]),
                area: points[k].contact_area,
                fluid: fluid(&points[k]),
            })
            .collect()
    };
    let (loops, ends) = hysteresis::find_loops(&states(&up), &states(&down), tolerance);
    for end in ends {
        let idx = if end.forward { &up } else { &down };
        let (a, b) = (idx[end.before], idx[end.after]);
        if !jumps
            .iter()
            .any(|j| j.branch == points[a].branch && j.index == a)
        {
            jumps.push(jump_row(points, a, b, f64::NAN, "loop"));
        }
    }
    jumps.sort_by_key(|j| (j.branch != "loading", j.index));
    loops
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
    for e in ended.iter().filter(|e| e.branch == "loading") {
        ctx.warn(format!("the forward branch ended early: {}", e.message));
    }
    bad.len()
}

/// What the artefact and the report hold besides the setup.
struct Sweep<'a> {
    points: &'a [Point],
    jumps: &'a [JumpRow],
    loops: &'a [Loop],
    ended: &'a [Ended],
}

fn write_artefact(
    out: &mut ArtefactWriter,
    setup: &Setup,
    surface: &crate::surface::SurfaceInput,
    (zone, spacings): (Option<f64>, f64),
    n_bad: usize,
    s: &Sweep,
) -> Result<()> {
    let base = setup.base;
    out.set_cell(surface.lx, surface.ly)?;
    out.set_attr("interaction", base.name())?;
    if let Interaction::Adhesion { gamma0, .. } = base {
        out.set_attr("gamma0", gamma0)?;
    }
    if let Interaction::Repulsion { gamma_r, .. } = base {
        out.set_attr("gamma_r", gamma_r)?;
    }
    out.set_attr("rho", base.range())?;
    out.set_attr("control", setup.control.as_str())?;
    out.set_attr("unit", setup.unit.as_str())?;
    out.set_attr("unit_scale", setup.scale)?;
    out.set_attr("p_fc", surface.p_fc)?;
    out.set_attr("lattice", surface.lattice.as_str())?;
    out.set_attr("n", surface.n)?;
    out.set_attr("nx", surface.nx as i64)?;
    out.set_attr("ny", surface.ny as i64)?;
    out.set_attr("dx", surface.lx / surface.nx as f64)?;
    out.set_attr("cohesive_zone_length", zone.unwrap_or(f64::NAN))?;
    out.set_attr("zone_spacings", spacings)?;
    out.set_attr("n_points", s.points.len() as i64)?;
    out.set_attr("n_unconverged", n_bad as i64)?;
    write_points(out, s.points)?;
    write_jumps(out, s.jumps)?;
    let col = |g: fn(&Loop) -> f64| s.loops.iter().map(g).collect::<Vec<f64>>();
    out.write_f64_1d("loops/x_lo", &col(|l| l.x.0))?;
    out.write_f64_1d("loops/x_hi", &col(|l| l.x.1))?;
    out.write_f64_1d("loops/max_area_difference", &col(|l| l.max_area_difference))?;
    out.write_f64_1d("loops/x_at_max", &col(|l| l.x_at_max))?;
    let ended = s.ended;
    out.write_strings(
        "ended/branch",
        &ended.iter().map(|e| e.branch.as_str()).collect::<Vec<_>>(),
    )?;
    out.write_f64_1d(
        "ended/load",
        &ended.iter().map(|e| e.load).collect::<Vec<_>>(),
    )?;
    out.write_f64_1d(
        "ended/strength",
        &ended.iter().map(|e| e.strength).collect::<Vec<_>>(),
    )?;
    out.write_strings(
        "ended/message",
        &ended.iter().map(|e| e.message.as_str()).collect::<Vec<_>>(),
    )?;
    Ok(())
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
            "branch": j.branch, "event": j.event, "detector": j.detector,
            "load_over_p_fc": [j.load.0 / p_fc, j.load.1 / p_fc],
            "area": [j.area.0, j.area.1],
        })).collect::<Vec<_>>(),
        "ended": s.ended.iter().map(|e| e.message.clone()).collect::<Vec<_>>(),
        "zone_spacings": if spacings.is_finite() { json!(spacings) } else { Value::Null },
    }))
}

fn write_points(out: &mut ArtefactWriter, p: &[Point]) -> Result<()> {
    let f = |out: &mut ArtefactWriter, k: &str, g: &dyn Fn(&Point) -> f64| {
        out.write_f64_1d(&format!("points/{k}"), &p.iter().map(g).collect::<Vec<_>>())
    };
    let i = |out: &mut ArtefactWriter, k: &str, g: &dyn Fn(&Point) -> i64| {
        out.write_i64_1d(&format!("points/{k}"), &p.iter().map(g).collect::<Vec<_>>())
    };
    let b = |out: &mut ArtefactWriter, k: &str, g: &dyn Fn(&Point) -> bool| {
        out.write_u8_1d(
            &format!("points/{k}"),
            &p.iter().map(|x| g(x) as u8).collect::<Vec<_>>(),
        )
    };
    out.write_strings(
        "points/branch",
        &p.iter().map(|x| x.branch.as_str()).collect::<Vec<_>>(),
    )?;
    i(out, "step", &|x| x.step)?;
    f(out, "load", &|x| x.load)?;
    f(out, "strength", &|x| x.strength)?;
    f(out, "contact_area", &|x| x.contact_area)?;
    f(out, "contact_area_corrected", &|x| x.contact_area_corrected)?;
    f(out, "mean_gap", &|x| x.mean_gap)?;
    f(out, "mean_displacement", &|x| x.mean_displacement)?;
    f(out, "energy", &|x| x.energy)?;
    i(out, "iterations", &|x| x.iterations)?;
    f(out, "max_violation", &|x| x.max_violation)?;
    f(out, "force_residual", &|x| x.force_residual)?;
    b(out, "converged", &|x| x.converged)?;
    out.write_strings(
        "points/stop_reason",
        &p.iter().map(|x| x.stop_reason.as_str()).collect::<Vec<_>>(),
    )?;
    f(out, "wall_s", &|x| x.wall_s)?;
    i(out, "contact_clusters", &|x| x.contact_clusters)?;
    b(out, "fluid_percolates_x", &|x| x.fluid_percolates_x)?;
    b(out, "fluid_percolates_y", &|x| x.fluid_percolates_y)?;
    Ok(())
}

fn write_jumps(out: &mut ArtefactWriter, j: &[JumpRow]) -> Result<()> {
    let f = |out: &mut ArtefactWriter, k: &str, g: &dyn Fn(&JumpRow) -> f64| {
        out.write_f64_1d(&format!("jumps/{k}"), &j.iter().map(g).collect::<Vec<_>>())
    };
    out.write_strings(
        "jumps/branch",
        &j.iter().map(|x| x.branch.as_str()).collect::<Vec<_>>(),
    )?;
    out.write_i64_1d(
        "jumps/index",
        &j.iter().map(|x| x.index as i64).collect::<Vec<_>>(),
    )?;
    out.write_i64_1d(
        "jumps/index_after",
        &j.iter().map(|x| x.index_after as i64).collect::<Vec<_>>(),
    )?;
    f(out, "load_before", &|x| x.load.0)?;
    f(out, "load_after", &|x| x.load.1)?;
    f(out, "strength_before", &|x| x.strength.0)?;
    f(out, "strength_after", &|x| x.strength.1)?;
    f(out, "area_before", &|x| x.area.0)?;
    f(out, "area_after", &|x| x.area.1)?;
    f(out, "ratio", &|x| x.ratio)?;
    out.write_strings(
        "jumps/event",
        &j.iter().map(|x| x.event.as_str()).collect::<Vec<_>>(),
    )?;
    out.write_strings(
        "jumps/detector",
        &j.iter().map(|x| x.detector.as_str()).collect::<Vec<_>>(),
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_expand_with_refinement() {
        let v = json!([{"from": 0.0, "to": 0.1, "steps": 2}, {"to": 0.2, "step": 0.025}]);
        let segs = parse_segments("path", &v, true, None).unwrap();
        let x = expand(&segs, 0.0, true);
        let want = [0.0, 0.05, 0.1, 0.125, 0.15, 0.175, 0.2];
        assert_eq!(x.len(), want.len());
        for (a, b) in x.iter().zip(want) {
            assert!((a - b).abs() < 1e-15, "{x:?}");
        }
        // the extension continues downwards from the start
        let e = parse_segments(
            "reverse_extension",
            &json!([{"to": -0.02, "steps": 2}]),
            false,
            Some(0.0),
        )
        .unwrap();
        assert_eq!(expand(&e, 0.0, false), [-0.01, -0.02]);
    }

    #[test]
    fn segment_errors_say_what_is_allowed() {
        let bad = |v: Value, fwd: bool| {
            parse_segments("path", &v, fwd, if fwd { None } else { Some(0.0) })
                .unwrap_err()
                .to_string()
        };
        assert!(bad(json!([{"to": 1.0, "steps": 2}]), true).contains("needs `from`"));
        assert!(bad(json!([{"from": 1.0, "to": 0.5, "steps": 2}]), true).contains("greater than"));
        assert!(bad(json!([{"from": 0.0, "to": 1.0}]), true).contains("`steps`"));
        assert!(
            bad(
                json!([{"from": 0.0, "to": 1.0, "steps": 2, "step": 0.1}]),
                true
            )
            .contains("not both")
        );
        assert!(
            bad(json!([{"from": 0.0, "to": 1.0, "stepz": 2}]), true)
                .contains("unknown key `stepz`")
        );
        assert!(
            bad(
                json!([{"from": 0.0, "to": 1.0, "steps": 2}, {"from": 2.0, "to": 3.0, "steps": 1}]),
                true
            )
            .contains("previous segment ends at 1")
        );
        assert!(bad(json!([{"to": 0.5, "steps": 2}]), false).contains("below"));
        assert!(bad(json!([]), true).contains("at least one"));
        assert!(bad(json!([{"from": 0.0, "to": 1.0, "step": 1e-9}]), true).contains("at most"));
    }
}
