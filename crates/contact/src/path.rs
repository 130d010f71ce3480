//! Quasi-static paths: loading and unloading branches in the mean pressure, or in the interaction
//! strength (γ0 or γr) at fixed load. Every step starts from the previous state (a warm start),
//! so metastable branches and hysteresis appear where they exist. The reverse branch retraces
//! the forward values and may continue below the first of them ([`PathSpec::extension`], e.g.
//! into tensile loads with adhesion); a branch ends early, recorded in [`PathResult::ended`],
//! when the surfaces separate (pull-off under force control).
//!
//! # Refinement of jumps
//! A step whose two states differ by a jump — a change of topology ([`run_with`]'s `topology`;
//! [`run`]: in contact or not, full contact or not) or of the relative contact area by more than
//! [`Refinement::area_jump`] — is refined by bisection of the control value from the earlier
//! state, [`Refinement::depth`] times: each midpoint is solved warm-started from the latest state
//! on the earlier side of the jump; if it has not jumped (relative to that state) it becomes the
//! new earlier state, otherwise the new later end. A step whose ends differ in topology is
//! bisected for the change of topology alone (the threshold it crosses, not a steep but
//! continuous change of area on the way), a step that keeps its topology for the area change. The jump is then located within
//! step/2^depth, whatever the minimiser. The midpoints go into the result in control order,
//! before the planned point, flagged [`PathPoint::refined`]. The planned point is then solved
//! again from the midpoint nearest to it (kept if that converges): past a refined jump the path
//! continues from the smaller step, as a quasi-static path should. Up to the first jump the
//! planned points are those of the unrefined path; after it they may differ (on grids that do
//! not resolve the cohesive zone, where the state reached depends on the step).

use crate::{ContactError, Interaction, Model, Solution, SolverOptions, StopReason};
use std::fmt;

/// Which direction a point was reached in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Branch {
    /// Control parameter increasing.
    Loading,
    /// Control parameter decreasing.
    Unloading,
}

impl Branch {
    /// "loading" or "unloading".
    pub fn name(self) -> &'static str {
        match self {
            Branch::Loading => "loading",
            Branch::Unloading => "unloading",
        }
    }
}

impl fmt::Display for Branch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Branch {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        [Branch::Loading, Branch::Unloading]
            .into_iter()
            .find(|b| b.name() == s)
            .ok_or_else(|| format!("branch `{s}`: allowed loading, unloading"))
    }
}

/// What a path varies.
#[derive(Debug, Clone, PartialEq)]
pub enum Control {
    /// The mean pressure takes `values` (increasing) on the loading branch, then the same values
    /// in reverse on the unloading branch.
    Load {
        /// Mean pressures of the loading branch (E* h0/λ), increasing.
        values: Vec<f64>,
    },
    /// The interaction strength (γ0 for adhesion, γr for repulsion) takes `values` (increasing),
    /// then the reverse, at fixed mean pressure `load`.
    Strength {
        /// Fixed mean pressure.
        load: f64,
        /// Strengths of the increasing branch, increasing.
        values: Vec<f64>,
    },
}

/// A quasi-static path.
#[derive(Debug, Clone, PartialEq)]
pub struct PathSpec {
    /// What is varied.
    pub control: Control,
    /// Whether to run the reverse branch after the forward one.
    pub reverse: bool,
    /// Control values (mean pressures or strengths, as `control`) that continue the reverse
    /// branch below the forward branch's first value, decreasing (empty: none).
    pub extension: Vec<f64>,
    /// Refinement of steps that jump (default: none).
    pub refine: Refinement,
}

/// Largest [`Refinement::depth`]: 2^-16 of a step is below any step a path plans (a path of
/// 10⁴ steps would locate its jumps to 1.5e-9 of its range).
pub const REFINE_DEPTH_MAX: u32 = 16;

/// How steps that jump are refined (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Refinement {
    /// Bisection levels per jumping step (0: none, at most [`REFINE_DEPTH_MAX`]): the jump is
    /// located within step/2^depth.
    pub depth: u32,
    /// Change of the relative contact area between two consecutive states beyond which a step
    /// is a jump (a change of topology always is), in (0, 1].
    pub area_jump: f64,
}

impl Default for Refinement {
    /// No refinement; a jump threshold of 0.02 in area (the sweep kind's loop tolerance).
    fn default() -> Self {
        Refinement {
            depth: 0,
            area_jump: 0.02,
        }
    }
}

/// One planned point of a path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlannedPoint {
    /// Branch.
    pub branch: Branch,
    /// Mean pressure (E* h0/λ).
    pub load: f64,
    /// The interaction at this point (its strength varied on a strength path).
    pub interaction: Interaction,
}

/// One solved point of a path.
#[derive(Debug, Clone, PartialEq)]
pub struct PathPoint {
    /// Branch.
    pub branch: Branch,
    /// Index in the plan ([`PathSpec::plan`]; forward and reverse branches numbered
    /// continuously).
    pub step: usize,
    /// Mean pressure (E* h0/λ).
    pub load: f64,
    /// Interaction strength (γ0 or γr; 0 for the hard wall).
    pub strength: f64,
    /// Relative contact area.
    pub contact_area: f64,
    /// Mean gap (h0).
    pub mean_gap: f64,
    /// Mean surface height of the body (h0).
    pub mean_displacement: f64,
    /// Energy per area (E* h0²/λ).
    pub energy: f64,
    /// Minimiser iterations.
    pub iterations: usize,
    /// Final constraint violation (h0).
    pub max_violation: f64,
    /// Final force residual (E* h0/λ).
    pub force_residual: f64,
    /// Converged within tolerance.
    pub converged: bool,
    /// Why the solve stopped without converging (`None` if it converged).
    pub stop_reason: Option<StopReason>,
    /// Wall time of the solve (s).
    pub wall_s: f64,
    /// A refinement point: a bisection midpoint of a step that jumped ([`Refinement`]), not in
    /// the plan (`step` is then the planned point it precedes).
    pub refined: bool,
}

/// A branch that ended early: no equilibrium was found at its next point because the surfaces
/// separated (pull-off under force control).
#[derive(Debug, Clone, PartialEq)]
pub struct PullOff {
    /// Branch.
    pub branch: Branch,
    /// Index in the plan of the point that had no equilibrium.
    pub step: usize,
    /// Its mean pressure (E* h0/λ).
    pub load: f64,
    /// Its strength (γ0 or γr; 0 for the hard wall).
    pub strength: f64,
    /// The mean pressure at which separation was detected (E* h0/λ).
    pub pressure: f64,
    /// The smallest gap then (h0).
    pub min_gap: f64,
}

/// A finished path.
#[derive(Debug, Clone, PartialEq)]
pub struct PathResult {
    /// Solved points in path order.
    pub points: Vec<PathPoint>,
    /// Branches that ended early (pull-off), in path order.
    pub ended: Vec<PullOff>,
    /// The jumps the refinement located, in path order: each the pair of consecutive points
    /// (indices into `points`) between which the bisection left it, the earlier one on the side
    /// the step started from. A step whose bisection met a non-converged midpoint has none.
    pub refined_jumps: Vec<RefinedJump>,
}

/// A jump located by refinement ([`PathResult::refined_jumps`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RefinedJump {
    /// Index in [`PathResult::points`] of the last point before the jump.
    pub before: usize,
    /// Index of the first point after it (`before + 1`).
    pub after: usize,
}

/// Why a path stopped.
#[derive(Debug, thiserror::Error)]
pub enum PathError {
    /// The path or the interaction is invalid.
    #[error(transparent)]
    Spec(#[from] ContactError),
    /// A point could not be solved (other than by pull-off, which ends its branch).
    #[error("{branch} branch, step {step}: load {load} E*h0/λ, {interaction:?}")]
    Solve {
        /// Branch.
        branch: Branch,
        /// Index in the plan.
        step: usize,
        /// Mean pressure (E* h0/λ).
        load: f64,
        /// The interaction there.
        interaction: Interaction,
        /// The solver's error.
        #[source]
        source: ContactError,
    },
    /// The observer failed (e.g. writing a field).
    #[error("{branch} branch, step {step}")]
    Observe {
        /// Branch.
        branch: Branch,
        /// Index in the plan.
        step: usize,
        /// The observer's error.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
}

impl PathSpec {
    /// Checks that the values are finite and strictly increasing, and the extension finite and
    /// strictly decreasing below the first value, and only with a reverse branch.
    pub fn validate(&self) -> Result<(), ContactError> {
        let values = match &self.control {
            Control::Load { values } => values,
            Control::Strength { load, values } => {
                if !load.is_finite() {
                    return Err(ContactError::parameter("load", *load, "finite"));
                }
                values
            }
        };
        if values.is_empty() {
            return Err(ContactError::Parameter {
                name: "values",
                value: "[]".into(),
                allowed: "at least one value",
            });
        }
        if let Some(v) = values
            .iter()
            .chain(&self.extension)
            .find(|v| !v.is_finite())
        {
            return Err(ContactError::parameter("values", *v, "finite numbers"));
        }
        if values.windows(2).any(|w| w[1] <= w[0]) {
            return Err(ContactError::Parameter {
                name: "values",
                value: format!("{values:?}"),
                allowed: "strictly increasing",
            });
        }
        let below = std::iter::once(&values[0]).chain(&self.extension);
        if below.clone().zip(below.skip(1)).any(|(a, b)| b >= a) {
            return Err(ContactError::Parameter {
                name: "extension",
                value: format!("{:?}", self.extension),
                allowed: "strictly decreasing below the first value",
            });
        }
        if self.refine.depth > REFINE_DEPTH_MAX {
            return Err(ContactError::parameter(
                "refine.depth",
                self.refine.depth as f64,
                "0 ..= 16 (REFINE_DEPTH_MAX)",
            ));
        }
        if !(self.refine.area_jump > 0.0 && self.refine.area_jump <= 1.0) {
            return Err(ContactError::parameter(
                "refine.area_jump",
                self.refine.area_jump,
                "0 < area_jump ≤ 1",
            ));
        }
        if !self.reverse && !self.extension.is_empty() {
            return Err(ContactError::Parameter {
                name: "extension",
                value: format!("{:?}", self.extension),
                allowed: "empty without a reverse branch (it continues the reverse branch)",
            });
        }
        Ok(())
    }

    /// The planned points for `interaction` (whose strength a strength path replaces): the
    /// forward values, then (if `reverse`) the same values backwards without the last one,
    /// followed by the extension. [`PathPoint::step`] indexes this list.
    pub fn plan(&self, interaction: Interaction) -> Vec<PlannedPoint> {
        let at = |branch: Branch, v: f64| match &self.control {
            Control::Load { .. } => PlannedPoint {
                branch,
                load: v,
                interaction,
            },
            Control::Strength { load, .. } => PlannedPoint {
                branch,
                load: *load,
                interaction: with_strength(interaction, v),
            },
        };
        let values = match &self.control {
            Control::Load { values } | Control::Strength { values, .. } => values,
        };
        let mut plan: Vec<PlannedPoint> = values.iter().map(|&v| at(Branch::Loading, v)).collect();
        if self.reverse {
            plan.extend(
                values
                    .iter()
                    .rev()
                    .skip(1)
                    .chain(&self.extension)
                    .map(|&v| at(Branch::Unloading, v)),
            );
        }
        plan
    }
}

/// `interaction` with its strength (γ0 or γr) replaced by `s` (the hard wall has none).
pub fn with_strength(interaction: Interaction, s: f64) -> Interaction {
    match interaction {
        Interaction::HardWall => Interaction::HardWall,
        Interaction::Adhesion { rho, .. } => Interaction::Adhesion { gamma0: s, rho },
        Interaction::Repulsion { rho, .. } => Interaction::Repulsion { gamma_r: s, rho },
    }
}

/// The strength of `interaction`: γ0, γr, or 0 for the hard wall.
pub fn strength(interaction: Interaction) -> f64 {
    match interaction {
        Interaction::HardWall => 0.0,
        Interaction::Adhesion { gamma0, .. } => gamma0,
        Interaction::Repulsion { gamma_r, .. } => gamma_r,
    }
}

/// The topology [`run`] tells jumps by: bit 0 in contact, bit 1 full contact.
pub fn contact_topology(sol: &Solution) -> u64 {
    u64::from(sol.contact_area > 0.0) | (u64::from(sol.contact_area >= 1.0) << 1)
}

/// Runs a path. `observe` sees every solved point with its full solution (to save fields or
/// measure more) and may stop the path with an error; the returned points are the path's
/// summary. A branch ends early, recorded in [`PathResult::ended`], when the surfaces separate
/// (pull-off); the next branch then starts cold. Jumps are refined as [`PathSpec::refine`]
/// says, told by [`contact_topology`] and the area ([`run_with`] for another topology).
pub fn run<E>(
    model: &mut Model,
    interaction: Interaction,
    spec: &PathSpec,
    opts: &SolverOptions,
    observe: impl FnMut(&PathPoint, &Solution) -> Result<(), E>,
) -> Result<PathResult, PathError>
where
    E: Into<Box<dyn std::error::Error + Send + Sync>>,
{
    run_with(model, interaction, spec, opts, contact_topology, observe)
}

/// [`run`], with jumps told by `topology` (any summary of a state: two consecutive states whose
/// summaries differ are a jump, e.g. bits for fluid percolation along each axis) besides the
/// area change [`Refinement::area_jump`]. Only used when [`Refinement::depth`] > 0.
pub fn run_with<E>(
    model: &mut Model,
    interaction: Interaction,
    spec: &PathSpec,
    opts: &SolverOptions,
    topology: impl Fn(&Solution) -> u64,
    mut observe: impl FnMut(&PathPoint, &Solution) -> Result<(), E>,
) -> Result<PathResult, PathError>
where
    E: Into<Box<dyn std::error::Error + Send + Sync>>,
{
    spec.validate()?;
    interaction.validate()?;
    let mut result = PathResult {
        points: Vec::new(),
        ended: Vec::new(),
        refined_jumps: Vec::new(),
    };
    // the previous planned point and its state (with its topology)
    let mut previous: Option<(PlannedPoint, Solution, u64)> = None;
    let mut skip_branch: Option<Branch> = None;
    let jumped = |a: &(Solution, u64), b: &(Solution, u64)| {
        a.1 != b.1 || (a.0.contact_area - b.0.contact_area).abs() > spec.refine.area_jump
    };
    for (step, planned) in spec.plan(interaction).into_iter().enumerate() {
        let PlannedPoint {
            branch,
            load,
            interaction: inter,
        } = planned;
        if skip_branch == Some(branch) {
            continue;
        }
        let sol = match model.solve(inter, load, opts, previous.as_ref().map(|p| &p.1)) {
            Ok(s) => s,
            Err(ContactError::Detached { pressure, min_gap }) => {
                result.ended.push(PullOff {
                    branch,
                    step,
                    load,
                    strength: strength(inter),
                    pressure,
                    min_gap,
                });
                skip_branch = Some(branch);
                previous = None;
                continue;
            }
            Err(source) => {
                return Err(PathError::Solve {
                    branch,
                    step,
                    load,
                    interaction: inter,
                    source,
                });
            }
        };
        let mut here = {
            let t = if spec.refine.depth > 0 {
                topology(&sol)
            } else {
                0
            };
            (sol, t)
        };
        if let Some((before, prev_sol, prev_t)) = previous.take()
            && spec.refine.depth > 0
            && prev_sol.stats.converged
            && here.0.stats.converged
        {
            let prev = (prev_sol, prev_t);
            if jumped(&prev, &here) {
                // a step that changes the topology is bisected for that change (the threshold
                // it crosses), one that does not for the area change
                let topological = prev.1 != here.1;
                let across = |a: &(Solution, u64), b: &(Solution, u64)| {
                    if topological {
                        a.1 != b.1
                    } else {
                        jumped(a, b)
                    }
                };
                let with_topology = |s: Solution| {
                    let t = topology(&s);
                    (s, t)
                };
                let ends = (before, planned);
                let (mids, lo) = bisect(
                    model,
                    opts,
                    spec.refine.depth,
                    ends,
                    step,
                    &prev,
                    with_topology,
                    &across,
                )?;
                // the planned start of the step is the last point so far
                let base = result.points.len();
                if let Some(lo) = lo {
                    let before = lo.map_or(base - 1, |k| base + k);
                    result.refined_jumps.push(RefinedJump {
                        before,
                        after: before + 1,
                    });
                }
                let mut nearest = None;
                for (mid, s) in mids {
                    let point = point_of(mid, step, &s, true);
                    observe(&point, &s).map_err(|e| PathError::Observe {
                        branch,
                        step,
                        source: e.into(),
                    })?;
                    result.points.push(point);
                    nearest = Some(s);
                }
                // the planned point again, from the refined state nearest to it: the path
                // continues from the smaller step
                if let Some(near) = nearest.filter(|s| s.stats.converged) {
                    match model.solve(inter, load, opts, Some(&near)) {
                        Ok(s) if s.stats.converged => here = with_topology(s),
                        Ok(_) | Err(ContactError::Detached { .. }) => {}
                        Err(source) => {
                            return Err(PathError::Solve {
                                branch,
                                step,
                                load,
                                interaction: inter,
                                source,
                            });
                        }
                    }
                }
            }
        }
        let point = point_of(planned, step, &here.0, false);
        observe(&point, &here.0).map_err(|e| PathError::Observe {
            branch,
            step,
            source: e.into(),
        })?;
        result.points.push(point);
        previous = Some((planned, here.0, here.1));
    }
    Ok(result)
}

/// The control value of a planned point (its load on a load path, its strength on a strength
/// path: the other one is the same at every point).
fn control_value(p: &PlannedPoint) -> (f64, f64) {
    (p.load, strength(p.interaction))
}

/// The midpoint of two planned points (same branch as `b`).
fn midpoint(a: &PlannedPoint, b: &PlannedPoint) -> PlannedPoint {
    let ((la, sa), (lb, sb)) = (control_value(a), control_value(b));
    PlannedPoint {
        branch: b.branch,
        // equal loads (strength path) or strengths (load path) stay bit-equal: 0.5 (x + x) = x
        load: 0.5 * (la + lb),
        interaction: with_strength(b.interaction, 0.5 * (sa + sb)),
    }
}

/// Bisects the step from `a` (state `from`) to `b` (plan index `step`), which jumped, `depth` times (see the module
/// doc); returns the midpoints solved, in control order from `a` to `b`, and the position among
/// them of the last one before the jump (`Some(None)`: `a` itself). A midpoint that does not
/// converge ends the bisection (it is returned, flagged, and the jump is not located: `None`);
/// one where the surfaces separate counts as jumped (nothing to return for it).
#[allow(clippy::too_many_arguments)]
fn bisect(
    model: &mut Model,
    opts: &SolverOptions,
    depth: u32,
    (a, b): (PlannedPoint, PlannedPoint),
    step: usize,
    from: &(Solution, u64),
    with_topology: impl Fn(Solution) -> (Solution, u64),
    jumped: &impl Fn(&(Solution, u64), &(Solution, u64)) -> bool,
) -> Result<Located, PathError> {
    let mut found: Vec<(PlannedPoint, (Solution, u64))> = Vec::new();
    // the earlier end: `None` is `a` with `from`, else an index into `found`
    let (mut lo, mut lo_state, mut hi) = (a, None::<usize>, b);
    let mut located = true;
    for _ in 0..depth {
        let mid = midpoint(&lo, &hi);
        let start = lo_state.map_or(from, |k| &found[k].1);
        let solved = model.solve(mid.interaction, mid.load, opts, Some(&start.0));
        match solved {
            Ok(s) => {
                let s = with_topology(s);
                let converged = s.0.stats.converged;
                let over = !converged || jumped(start, &s);
                found.push((mid, s));
                if !converged {
                    located = false;
                    break;
                }
                if over {
                    hi = mid;
                } else {
                    lo = mid;
                    lo_state = Some(found.len() - 1);
                }
            }
            Err(ContactError::Detached { .. }) => hi = mid,
            Err(source) => {
                return Err(PathError::Solve {
                    branch: mid.branch,
                    step,
                    load: mid.load,
                    interaction: mid.interaction,
                    source,
                });
            }
        }
    }
    let (la, sa) = control_value(&a);
    let distance = |p: &PlannedPoint| {
        let (l, s) = control_value(p);
        (l - la).abs() + (s - sa).abs()
    };
    let lo_x = lo_state.map(|k| distance(&found[k].0));
    found.sort_by(|x, y| distance(&x.0).total_cmp(&distance(&y.0)));
    let lo_pos = lo_x.map(|d| {
        found
            .iter()
            .position(|f| distance(&f.0) == d)
            .expect("the earlier end is among the midpoints")
    });
    let mids = found.into_iter().map(|(p, (s, _))| (p, s)).collect();
    Ok((mids, located.then_some(lo_pos)))
}

/// What [`bisect`] returns: the midpoints in control order, and where the jump lies.
type Located = (Vec<(PlannedPoint, Solution)>, Option<Option<usize>>);

fn point_of(planned: PlannedPoint, step: usize, sol: &Solution, refined: bool) -> PathPoint {
    PathPoint {
        branch: planned.branch,
        step,
        load: planned.load,
        strength: strength(planned.interaction),
        contact_area: sol.contact_area,
        mean_gap: sol.mean_gap,
        mean_displacement: sol.mean_displacement,
        energy: sol.energy,
        iterations: sol.stats.iterations,
        max_violation: sol.stats.max_violation,
        force_residual: sol.stats.force_residual,
        converged: sol.stats.converged,
        stop_reason: sol.stats.reason.clone(),
        wall_s: sol.stats.wall_s,
        refined,
    }
}

/// [`run`] with an observer that cannot fail, and solver errors as [`ContactError`].
pub fn sweep(
    model: &mut Model,
    interaction: Interaction,
    spec: &PathSpec,
    opts: &SolverOptions,
    mut observe: impl FnMut(&PathPoint, &Solution),
) -> Result<PathResult, ContactError> {
    run(model, interaction, spec, opts, |p, s| {
        observe(p, s);
        Ok::<(), std::convert::Infallible>(())
    })
    .map_err(|e| match e {
        PathError::Spec(e) | PathError::Solve { source: e, .. } => e,
        PathError::Observe { .. } => unreachable!("the observer cannot fail"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Lattice, Surface};

    fn spec(values: Vec<f64>, extension: Vec<f64>) -> PathSpec {
        PathSpec {
            control: Control::Load { values },
            reverse: true,
            extension,
            refine: Refinement::default(),
        }
    }

    #[test]
    fn plan_retraces_and_extends() {
        let s = spec(vec![1.0, 2.0, 3.0], vec![0.5, 0.0]);
        let plan = s.plan(Interaction::HardWall);
        let loads: Vec<f64> = plan.iter().map(|p| p.load).collect();
        assert_eq!(loads, [1.0, 2.0, 3.0, 2.0, 1.0, 0.5, 0.0]);
        let loading = plan.iter().filter(|p| p.branch == Branch::Loading).count();
        assert_eq!(loading, 3);
        let gamma = PathSpec {
            control: Control::Strength {
                load: 0.1,
                values: vec![0.1, 0.2],
            },
            reverse: true,
            extension: vec![],
            refine: Refinement::default(),
        };
        let adhesion = Interaction::Adhesion {
            gamma0: 9.0,
            rho: 0.04,
        };
        let plan = gamma.plan(adhesion);
        let st: Vec<f64> = plan.iter().map(|p| strength(p.interaction)).collect();
        assert_eq!(st, [0.1, 0.2, 0.1]);
        assert!(plan.iter().all(|p| p.load == 0.1));
    }

    #[test]
    fn invalid_extensions_are_rejected() {
        assert!(spec(vec![1.0, 2.0], vec![1.0]).validate().is_err());
        assert!(spec(vec![1.0, 2.0], vec![0.5, 0.7]).validate().is_err());
        let mut s = spec(vec![1.0, 2.0], vec![0.5]);
        assert!(s.validate().is_ok());
        s.reverse = false;
        assert!(s.validate().is_err());
    }

    #[test]
    fn invalid_refinements_are_rejected() {
        let mut s = spec(vec![1.0, 2.0], vec![]);
        s.refine.depth = REFINE_DEPTH_MAX;
        assert!(s.validate().is_ok());
        s.refine.depth = REFINE_DEPTH_MAX + 1;
        assert!(s.validate().is_err());
        s.refine.depth = 3;
        for bad in [0.0, -0.1, 1.5, f64::NAN] {
            s.refine.area_jump = bad;
            assert!(s.validate().is_err(), "area_jump {bad}");
        }
    }

    /// Unloading an adhesive contact into tension ends in pull-off, recorded, not an error;
    /// every point is warm-started from the previous one, so the reverse branch at the top
    /// value reproduces the forward branch's state there.
    #[test]
    fn adhesive_unloading_ends_in_pull_off() {
        let s = Surface::new(Lattice::Square, 4).unwrap();
        let mut m = Model::new(&s).unwrap();
        let p_fc = s.p_fc_grid();
        let inter = Interaction::Adhesion {
            gamma0: 0.2,
            rho: 0.25,
        };
        let values: Vec<f64> = [0.05, 0.1].iter().map(|f| f * p_fc).collect();
        let extension: Vec<f64> = (1..=40).map(|k| (0.05 - 0.05 * k as f64) * p_fc).collect();
        let spec = spec(values, extension);
        let mut seen = 0;
        let r = run(&mut m, inter, &spec, &SolverOptions::default(), |_, _| {
            seen += 1;
            Ok::<(), std::convert::Infallible>(())
        })
        .unwrap();
        assert_eq!(seen, r.points.len());
        assert_eq!(r.ended.len(), 1, "{:?}", r.ended);
        let end = &r.ended[0];
        assert_eq!(end.branch, Branch::Unloading);
        assert!(end.load < 0.0, "pull-off needs tension: {end:?}");
        // the branch stops at the pull-off point: nothing after it was solved
        assert!(r.points.iter().all(|p| p.step < end.step));
        assert!(
            r.points
                .iter()
                .all(|p| p.converged && p.stop_reason.is_none())
        );
    }
}
