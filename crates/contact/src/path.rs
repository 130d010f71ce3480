//! Quasi-static paths: loading and unloading branches in the mean pressure, or in the interaction
//! strength (γ0 or γr) at fixed load. Every step starts from the previous state, so metastable
//! branches and hysteresis appear where they exist.

use crate::{ContactError, Interaction, Model, Solution, SolverOptions};

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
}

/// One solved point of a path.
#[derive(Debug, Clone, PartialEq)]
pub struct PathPoint {
    /// Branch.
    pub branch: Branch,
    /// Index along the path (forward and reverse branches numbered continuously).
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
    /// Wall time of the solve (s).
    pub wall_s: f64,
}

/// A finished path.
#[derive(Debug, Clone, PartialEq)]
pub struct PathResult {
    /// Solved points in path order.
    pub points: Vec<PathPoint>,
    /// Why a branch ended early (e.g. pull-off), if it did.
    pub ended: Vec<String>,
}

impl PathSpec {
    /// Checks that the values are finite and strictly increasing.
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
        if let Some(v) = values.iter().find(|v| !v.is_finite()) {
            return Err(ContactError::parameter("values", *v, "finite numbers"));
        }
        if values.windows(2).any(|w| w[1] <= w[0]) {
            return Err(ContactError::Parameter {
                name: "values",
                value: format!("{values:?}"),
                allowed: "strictly increasing",
            });
        }
        Ok(())
    }
}

fn with_strength(interaction: Interaction, s: f64) -> Interaction {
    match interaction {
        Interaction::HardWall => Interaction::HardWall,
        Interaction::Adhesion { rho, .. } => Interaction::Adhesion { gamma0: s, rho },
        Interaction::Repulsion { rho, .. } => Interaction::Repulsion { gamma_r: s, rho },
    }
}

fn strength(interaction: Interaction) -> f64 {
    match interaction {
        Interaction::HardWall => 0.0,
        Interaction::Adhesion { gamma0, .. } => gamma0,
        Interaction::Repulsion { gamma_r, .. } => gamma_r,
    }
}

/// Runs a path. `observe` sees every solved point with its full solution (to save fields); the
/// returned points are the path's summary. A branch ends early, with a note in
/// [`PathResult::ended`], when the surfaces separate (pull-off under a tensile load).
pub fn sweep(
    model: &mut Model,
    interaction: Interaction,
    spec: &PathSpec,
    opts: &SolverOptions,
    mut observe: impl FnMut(&PathPoint, &Solution),
) -> Result<PathResult, ContactError> {
    spec.validate()?;
    interaction.validate()?;
    let forward: Vec<(f64, Interaction)> = match &spec.control {
        Control::Load { values } => values.iter().map(|&p| (p, interaction)).collect(),
        Control::Strength { load, values } => values
            .iter()
            .map(|&s| (*load, with_strength(interaction, s)))
            .collect(),
    };
    let mut plan: Vec<(Branch, f64, Interaction)> = forward
        .iter()
        .map(|&(p, i)| (Branch::Loading, p, i))
        .collect();
    if spec.reverse {
        plan.extend(
            forward
                .iter()
                .rev()
                .skip(1)
                .map(|&(p, i)| (Branch::Unloading, p, i)),
        );
    }
    let mut result = PathResult {
        points: Vec::new(),
        ended: Vec::new(),
    };
    let mut previous: Option<Solution> = None;
    let mut skip_branch: Option<Branch> = None;
    for (step, (branch, load, inter)) in plan.into_iter().enumerate() {
        if skip_branch == Some(branch) {
            continue;
        }
        let sol = match model.solve(inter, load, opts, previous.as_ref()) {
            Ok(s) => s,
            Err(ContactError::Detached { pressure, min_gap }) => {
                result.ended.push(format!(
                    "{} branch ended at step {step}: surfaces separated at mean pressure {pressure} (min gap {min_gap})",
                    branch.name()
                ));
                skip_branch = Some(branch);
                previous = None;
                continue;
            }
            Err(e) => return Err(e),
        };
        let point = PathPoint {
            branch,
            step,
            load,
            strength: strength(inter),
            contact_area: sol.contact_area,
            mean_gap: sol.mean_gap,
            mean_displacement: sol.mean_displacement,
            energy: sol.energy,
            iterations: sol.stats.iterations,
            max_violation: sol.stats.max_violation,
            force_residual: sol.stats.force_residual,
            converged: sol.stats.converged,
            wall_s: sol.stats.wall_s,
        };
        observe(&point, &sol);
        result.points.push(point);
        previous = Some(sol);
    }
    Ok(result)
}
