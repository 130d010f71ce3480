//! Force-controlled Green's-function (GFMD) contact mechanics of a flat elastic half-space
//! against a rigid periodic surface, with hard-wall, adhesive and repulsive interactions.
//!
//! Conventions: see [`elastic`] for the one place the sign convention is fixed (gap
//! `g = u − h ≥ 0`, `u` the elastic surface's height). Units: E* = 1, λ = 1, h0 = 1; pressures in
//! E* h0/λ, energies per area in E* h0²/λ.
//!
//! Three minimisers implement [`Minimizer`]:
//! - [`polonsky_keer::PolonskyKeer`]: constrained conjugate gradients in the contact pressure
//!   (Polonsky & Keer 1999), preconditioned by the elastic stiffness (Vollebregt 2014), for the
//!   convex hard-wall problem. Converges to a bound on the constraint violation (gap on the
//!   contact set, penetration off it).
//! - [`fire::Fire`]: FIRE relaxation of the displacement with Fourier-space mass weighting
//!   (masses ∝ modal stiffness, Zhou, Moseler & Müser 2019) and the hard wall as a projection;
//!   handles any interaction and follows metastable branches from warm starts. Converges to a
//!   bound on the force residual.
//! - [`nonlinear_cg::NonlinearCg`]: bound-constrained nonlinear conjugate gradients on the
//!   displacement, preconditioned by the elastic stiffness, with a line search that stops at the
//!   first minimum along the ray; any interaction, follows metastable branches from warm starts,
//!   converges to the same force-residual bound as FIRE in 3–5× fewer iterations; what
//!   [`Method::Auto`] chooses for adhesion and repulsion where the cohesive zone spans a grid
//!   spacing ([`NCG_MIN_ZONE_SPACINGS`]), FIRE below.
//!
//! [`Model::solve`] picks one, warm-starts from a previous [`Solution`] if given, and always
//! returns the iterations, residuals and a converged flag; [`path`] runs quasi-static loading and
//! unloading branches.

pub mod compliance;
pub mod elastic;
pub mod fire;
pub mod free_kernel;
pub mod interaction;
pub mod nonlinear_cg;
pub mod path;
pub mod polonsky_keer;
pub mod refinement;
pub mod spectral;
mod stop_monitor;

pub use interaction::Interaction;
pub use surface::{Grid, Lattice, Surface};

use elastic::ElasticKernel;
use ndarray::{Array2, ArrayView2};
use std::fmt;
use std::time::Instant;

/// Errors of the contact solver.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ContactError {
    /// A parameter outside its allowed range.
    #[error("invalid {name} = {value}: allowed {allowed}")]
    Parameter {
        /// Parameter name.
        name: &'static str,
        /// Offending value, as given.
        value: String,
        /// Allowed range, in words.
        allowed: &'static str,
    },
    /// Heights that are not finite.
    #[error("height field has a non-finite value {value} at node ({i}, {j})")]
    Heights {
        /// Offending value.
        value: f64,
        /// x index.
        i: usize,
        /// y index.
        j: usize,
    },
    /// A warm start for a different grid.
    #[error("warm start has {got} nodes but the grid has {want}")]
    WarmStart {
        /// Nodes in the warm start.
        got: usize,
        /// Nodes in the grid.
        want: usize,
    },
    /// A warm start holding a non-finite value.
    #[error("warm start has a non-finite {field} value {value} at node {index}")]
    WarmStartNonFinite {
        /// `displacement` or `pressure`.
        field: &'static str,
        /// Offending value.
        value: f64,
        /// Flat node index.
        index: usize,
    },
    /// A mean pressure outside the range a solve can represent (see [`PRESSURE_MIN`] and
    /// [`pressure_max`]).
    #[error("invalid pressure = {value:?} E* h0/λ: allowed {allowed}")]
    Pressure {
        /// Offending mean pressure.
        value: f64,
        /// Allowed range with its reason, in words.
        allowed: String,
    },
    /// The body lost all contact under a tensile or zero load: there is no equilibrium.
    #[error(
        "the surfaces separated at mean pressure {pressure} (no contact, minimum gap {min_gap} > 20ρ): \
         there is no equilibrium under force control beyond pull-off"
    )]
    Detached {
        /// Imposed mean pressure.
        pressure: f64,
        /// Smallest gap when separation was detected.
        min_gap: f64,
    },
}

impl ContactError {
    pub(crate) fn parameter(name: &'static str, value: f64, allowed: &'static str) -> Self {
        ContactError::Parameter {
            name,
            // Debug switches to exponent notation for tiny and huge values (1e-300, not 300
            // digits)
            value: format!("{value:?}"),
            allowed,
        }
    }
}

/// Largest accepted [`SolverOptions::tol_gap`] (h0). Heights span a few h0 and the gaps near
/// percolation are far smaller: a violation of 1e-3 h0 is already a 0.1 % error in every gap of
/// the surface, and a tolerance as large as the heights let Polonsky–Keer stop on its uniform
/// start, reporting full contact after 0 iterations (issue 18).
pub const TOL_GAP_MAX: f64 = 1e-3;

/// Largest accepted [`SolverOptions::tol_force`] (E* h0/λ): 1e-3 of the pressure scale E* h0/λ,
/// below 2e-4 of the full-contact pressures of the paper's models (2π for the square model) and
/// of the adhesive stresses γ0/ρ of the paper's parameters.
pub const TOL_FORCE_MAX: f64 = 1e-3;

/// Smallest accepted positive mean pressure without adhesion (E* h0/λ). The minimisers form
/// squares and products of pressures and displacements: at 1e-60 these stay above 1e-120 times
/// the grid's factors, nearly 190 decades above the smallest normal double, while the square
/// model broke down (NaN) at 6e-120 E* h0/λ. Nothing is lost: far above this bound the load
/// already sits on the highest node alone (area 1/N), as it does for any smaller load.
pub const PRESSURE_MIN: f64 = 1e-60;

/// Largest accepted |mean pressure| (E* h0/λ) for a constraint tolerance `tol_gap` on a cell of
/// longest side `l`. The pressure field p̄ + σ is stored to absolute precision ε p̄ (ε the machine
/// epsilon); an error δp in the longest mode (wavenumber 2π/l) moves the surface by δp l/(π E*),
/// so beyond π E* tol_gap/(ε l) rounding alone violates the constraints by more than the
/// tolerance and no solve can be trusted (measured on the square model at n = 5: a violation
/// floor of 0.16 ε p̄, within this bound's 0.32 ε p̄). Every load above the full-contact pressure
/// (2π E* h0/λ for the square model, about 1e-5 of this bound at the default tolerance) gives
/// full contact anyway.
pub fn pressure_max(tol_gap: f64, l: f64) -> f64 {
    std::f64::consts::PI * tol_gap / (f64::EPSILON * l)
}

/// Smallest cohesive-zone length ρ²E*/γ, in grid spacings, at which [`Method::Auto`] uses
/// nonlinear CG for adhesion and repulsion; below it uses FIRE. Where the zone is below the
/// spacing, the discrete problem has many lattice-trapped metastable states separated by tiny
/// barriers, and which one a warm start relaxes into depends on the minimiser, not on the
/// physics. Measured on the draft preset (tables of `saddleflow run --params params/draft.toml`
/// against FIRE everywhere; tolerance 1e-8):
/// - nonlinear CG everywhere: Figure 2's jumps and loops on 128² (1.02 spacings) unchanged, but
///   on 64² (0.51) two lattice jumps of the repulsive path vanish, and Figure 3's γ0 paths (down
///   to 1e-3 spacings) end on other branches: γ_fc of the triangular model on 128² 4.25 → 27.5,
///   γ_fc/γ_p of the hexagonal one 153 → 113;
/// - threshold 0.5: Figure 2 as with FIRE on both grids but for those two lattice jumps; γ_fc of
///   the square model on 64² 42.5 → 32.5 (two path steps);
/// - threshold 1 (this): every jump of Figure 2 on both grids unchanged, loops unchanged, areas
///   within 52 of 16384 nodes (lattice trapping at 11 of 328 points on 128²); Figure 3's jumps
///   unchanged but on the square model's 64² grid: full contact one path step earlier (γ_fc
///   42.5 → 37.5) and a lattice jump at γ0 ≈ 17 gone. That change and the
///   square model's other area differences (≤ 74 nodes on 128²) arise at γ0 ≥ 1.8, where FIRE
///   runs in both: the states handed over at γ0 ≤ 0.2 differ at the tolerance level (mean gap
///   ≤ 1e-7), and FIRE's outcome on the under-resolved grid depends on that: FIRE alone at
///   tolerance 1e-9 instead of 1e-8 moves γ_fc of the square model on 64² from 40–45 to 25–30
///   and of the hexagonal model on 128² from 18.3–20 to 10–11.7. Below a spacing, no minimiser
///   fixes these jumps to within a path step.
pub const NCG_MIN_ZONE_SPACINGS: f64 = 1.0;

/// Which minimiser to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Method {
    /// Polonsky–Keer for the hard wall; nonlinear CG for adhesion and repulsion whose cohesive
    /// zone spans at least [`NCG_MIN_ZONE_SPACINGS`] grid spacings, FIRE below (see there).
    #[default]
    Auto,
    /// Constrained conjugate gradients, stiffness-preconditioned (hard wall only).
    PolonskyKeer,
    /// Constrained conjugate gradients without the preconditioner (hard wall only; for
    /// comparison).
    PolonskyKeerPlain,
    /// Mass-weighted FIRE (any interaction).
    Fire,
    /// Stiffness-preconditioned nonlinear conjugate gradients (any interaction).
    NonlinearCg,
}

impl Method {
    /// Every method, in the order parameter lists show them.
    pub const ALL: [Method; 5] = [
        Method::Auto,
        Method::PolonskyKeer,
        Method::PolonskyKeerPlain,
        Method::Fire,
        Method::NonlinearCg,
    ];

    /// The name [`FromStr`](std::str::FromStr) reads and [`Display`](std::fmt::Display) writes.
    pub fn name(self) -> &'static str {
        match self {
            Method::Auto => "auto",
            Method::PolonskyKeer => "polonsky-keer",
            Method::PolonskyKeerPlain => "polonsky-keer-plain",
            Method::Fire => "fire",
            Method::NonlinearCg => "nonlinear-cg",
        }
    }

    /// Whether the method solves the hard wall only (Polonsky–Keer, either variant).
    pub fn hard_wall_only(self) -> bool {
        matches!(self, Method::PolonskyKeer | Method::PolonskyKeerPlain)
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Method {
    type Err = ContactError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if let Some(m) = Method::ALL.into_iter().find(|m| m.name() == s) {
            return Ok(m);
        }
        match s {
            "pk" => Ok(Method::PolonskyKeer),
            "pk-plain" => Ok(Method::PolonskyKeerPlain),
            "ncg" => Ok(Method::NonlinearCg),
            _ => Err(ContactError::Parameter {
                name: "method",
                value: s.to_string(),
                allowed: "\"auto\", \"polonsky-keer\", \"polonsky-keer-plain\" (hard wall only), \"fire\" or \"nonlinear-cg\"",
            }),
        }
    }
}

/// Convergence criteria and limits.
#[derive(Debug, Clone, PartialEq)]
pub struct SolverOptions {
    /// Bound on the constraint violation (h0): the largest |gap| on the contact set and the
    /// largest penetration off it. Polonsky–Keer stops on this.
    pub tol_gap: f64,
    /// Bound on the force-balance residual (E* h0/λ): the largest unbalanced pressure at a
    /// non-contact node, or the largest pull-off pressure at a contact node. FIRE stops on this.
    pub tol_force: f64,
    /// Iteration cap.
    pub max_iter: usize,
    /// Minimiser.
    pub method: Method,
    /// Record the objective at every iteration in [`SolveStats::trace`].
    pub trace: bool,
}

impl Default for SolverOptions {
    fn default() -> Self {
        SolverOptions {
            tol_gap: 1e-10,
            tol_force: 1e-8,
            max_iter: 200_000,
            method: Method::Auto,
            trace: false,
        }
    }
}

impl SolverOptions {
    /// Checks the options.
    pub fn validate(&self) -> Result<(), ContactError> {
        if !(self.tol_gap > 0.0 && self.tol_gap <= TOL_GAP_MAX) {
            return Err(ContactError::parameter(
                "tol_gap",
                self.tol_gap,
                "0 < tol_gap ≤ 1e-3 (h0; TOL_GAP_MAX)",
            ));
        }
        if !(self.tol_force > 0.0 && self.tol_force <= TOL_FORCE_MAX) {
            return Err(ContactError::parameter(
                "tol_force",
                self.tol_force,
                "0 < tol_force ≤ 1e-3 (E* h0/λ; TOL_FORCE_MAX)",
            ));
        }
        if self.max_iter == 0 {
            return Err(ContactError::parameter("max_iter", 0.0, "≥ 1"));
        }
        Ok(())
    }
}

/// Why a minimiser stopped without meeting its tolerance.
#[derive(Debug, Clone, PartialEq)]
pub enum StopReason {
    /// Hit the iteration cap while still improving.
    IterationCap,
    /// No progress for many iterations: the tolerance is below what rounding allows, or the state
    /// sits at an instability.
    Stagnation,
    /// The residual grew by orders of magnitude.
    ResidualGrowth,
    /// The state holds NaN or infinite values.
    NonFinite,
    /// The surface and the start were symmetric under inversion through the origin node
    /// (r → −r, a symmetry of every model's sampling), the unconverged state is not: rounding
    /// noise grew along an unstable mode. `defect` is max |u(r) − u(−r)| (h0).
    LossOfSymmetry {
        /// Largest displacement difference between inverted nodes (h0).
        defect: f64,
    },
    /// The minimiser reported convergence but the independent evaluation of its state
    /// ([`residuals`]) exceeds the tolerance it stops on.
    Unverified {
        /// `constraint violation` or `force residual`.
        measure: &'static str,
        /// The independent value (h0 or E* h0/λ).
        value: f64,
        /// The tolerance.
        tol: f64,
    },
}

impl fmt::Display for StopReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let StopReason::LossOfSymmetry { defect } = self {
            return write!(
                f,
                "the state lost the surface's inversion symmetry (max |u(r) − u(−r)| = {defect:.2e} h0 from a \
                 symmetric start): it sits at an instability, where the branch ends; a tighter tolerance or \
                 more iterations will not help — take a smaller load or γ0 step to locate the jump, or \
                 warm-start from a state on the branch you want to follow"
            );
        }
        if let StopReason::Unverified {
            measure,
            value,
            tol,
        } = self
        {
            return write!(
                f,
                "the minimiser stopped as converged, but an independent evaluation finds the \
                 {measure} {value:.3e} above the tolerance {tol:.3e}: the state is not a solution \
                 (please report the case)"
            );
        }
        f.write_str(match self {
            StopReason::IterationCap => {
                "iteration cap reached while the residual was still falling: raise max_iter, or warm-start \
                 from a nearby solution"
            }
            StopReason::Stagnation => {
                "residual stagnated: the tolerance is likely below rounding for this grid (loosen tol_gap / \
                 tol_force), or the state is at an instability (use smaller load steps)"
            }
            StopReason::ResidualGrowth => {
                "residual grew by orders of magnitude (diverging): reduce the load step, check ρ against the \
                 grid spacing, or use FIRE"
            }
            StopReason::NonFinite => {
                "the state became non-finite (NaN or infinity): a numerical breakdown; try the other \
                 method (polonsky-keer / fire) and please report the case"
            }
            StopReason::LossOfSymmetry { .. } | StopReason::Unverified { .. } => {
                unreachable!("written above")
            }
        })
    }
}

/// Statistics of one solve.
#[derive(Debug, Clone, PartialEq)]
pub struct SolveStats {
    /// Minimiser used.
    pub method: &'static str,
    /// Iterations (each costs one or two FFT pairs).
    pub iterations: usize,
    /// Whether the tolerance was met.
    pub converged: bool,
    /// Why it stopped, if not converged.
    pub reason: Option<StopReason>,
    /// Final constraint violation (h0), see [`SolverOptions::tol_gap`].
    pub max_violation: f64,
    /// Final force residual (E* h0/λ), see [`SolverOptions::tol_force`].
    pub force_residual: f64,
    /// Wall time (s).
    pub wall_s: f64,
    /// Objective per iteration if requested (Polonsky–Keer: complementary energy; FIRE:
    /// potential plus kinetic energy), per unit area.
    pub trace: Vec<f64>,
}

/// A solved contact state.
#[derive(Debug, Clone)]
pub struct Solution {
    /// Grid of the fields.
    pub grid: Grid,
    /// Interaction used.
    pub interaction: Interaction,
    /// Imposed mean pressure p̄ (E* h0/λ).
    pub mean_pressure: f64,
    /// Elastic surface height u (h0), shape (nx, ny); the gap is u − h.
    pub displacement: Array2<f64>,
    /// Gap g = u − h ≥ 0 (h0); exactly 0 at contact nodes.
    pub gap: Array2<f64>,
    /// Pressure the substrate exerts on the body, σ + p̄ (E* h0/λ; compressive positive, negative
    /// in adhesive necks).
    pub pressure: Array2<f64>,
    /// Fraction of nodes in contact (g = 0).
    pub contact_area: f64,
    /// Mean gap (h0).
    pub mean_gap: f64,
    /// Mean of u (h0): the body's rigid position.
    pub mean_displacement: f64,
    /// Total energy per area: elastic + load + interaction (E* h0²/λ).
    pub energy: f64,
    /// Solver statistics.
    pub stats: SolveStats,
}

/// A contact problem's fixed part: grid, heights and elastic kernel (with its FFT plans and
/// buffers). Build once per surface and solve many loads on it.
pub struct Model {
    grid: Grid,
    heights: Vec<f64>,
    h_max: f64,
    /// The heights are symmetric under r → −r (to rounding): loss of symmetry can be diagnosed.
    symmetric: bool,
    kernel: ElasticKernel,
    /// The free-boundary kernel, if the problem is not periodic (see [`free_kernel`]); the
    /// Polonsky–Keer minimiser then uses it instead of `kernel`.
    free: Option<free_kernel::FreeKernel>,
}

impl Model {
    /// Model for a sampled surface.
    pub fn new(surface: &Surface) -> Result<Self, ContactError> {
        Self::from_heights(surface.grid, surface.heights.view())
    }

    /// Model for any height field of shape (nx, ny) on `grid` (nx, ny even).
    pub fn from_heights(grid: Grid, heights: ArrayView2<f64>) -> Result<Self, ContactError> {
        if heights.dim() != (grid.nx, grid.ny) {
            return Err(ContactError::Parameter {
                name: "heights",
                value: format!("shape {:?}", heights.dim()),
                allowed: "shape (nx, ny) of the grid",
            });
        }
        if grid.nx < 2 || grid.ny < 2 || grid.nx % 2 == 1 || grid.ny % 2 == 1 {
            return Err(ContactError::Parameter {
                name: "grid",
                value: format!("{} × {}", grid.nx, grid.ny),
                allowed: "even node counts ≥ 2 along both axes",
            });
        }
        if !(grid.lx.is_finite() && grid.lx > 0.0 && grid.ly.is_finite() && grid.ly > 0.0) {
            return Err(ContactError::Parameter {
                name: "cell",
                value: format!("{} × {}", grid.lx, grid.ly),
                allowed: "finite and > 0",
            });
        }
        if let Some(((i, j), &value)) = heights.indexed_iter().find(|(_, v)| !v.is_finite()) {
            return Err(ContactError::Heights { value, i, j });
        }
        let heights: Vec<f64> = heights.iter().copied().collect();
        let h_max = heights.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let symmetric =
            inversion_defect(&grid, &heights) <= SYMMETRY_ROUNDING * h_max.abs().max(1.0);
        Ok(Model {
            kernel: ElasticKernel::new(&grid, 1.0),
            grid,
            heights,
            h_max,
            symmetric,
            free: None,
        })
    }

    /// The grid.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// Heights, row-major (first index x).
    pub fn heights(&self) -> &[f64] {
        &self.heights
    }

    /// Solves for mean pressure `pressure`, warm-starting from `warm` if given, with the
    /// minimiser `opts.method` selects.
    pub fn solve(
        &mut self,
        interaction: Interaction,
        pressure: f64,
        opts: &SolverOptions,
        warm: Option<&Solution>,
    ) -> Result<Solution, ContactError> {
        match opts.method {
            Method::Auto if interaction.is_hard_wall() && pressure > 0.0 => self.solve_with(
                &polonsky_keer::PolonskyKeer::default(),
                interaction,
                pressure,
                opts,
                warm,
            ),
            Method::PolonskyKeer | Method::PolonskyKeerPlain => self.solve_with(
                &polonsky_keer::PolonskyKeer {
                    preconditioned: opts.method == Method::PolonskyKeer,
                },
                interaction,
                pressure,
                opts,
                warm,
            ),
            Method::Auto if !self.resolves_cohesive_zone(interaction) => {
                self.solve_with(&fire::Fire::default(), interaction, pressure, opts, warm)
            }
            Method::Auto | Method::NonlinearCg => self.solve_with(
                &nonlinear_cg::NonlinearCg::default(),
                interaction,
                pressure,
                opts,
                warm,
            ),
            Method::Fire => {
                self.solve_with(&fire::Fire::default(), interaction, pressure, opts, warm)
            }
        }
    }

    /// Whether the cohesive zone ρ²E*/γ of `interaction` spans at least
    /// [`NCG_MIN_ZONE_SPACINGS`] of the grid's coarser spacing (true without one: no strength).
    pub fn resolves_cohesive_zone(&self, interaction: Interaction) -> bool {
        let dx = (self.grid.lx / self.grid.nx as f64).max(self.grid.ly / self.grid.ny as f64);
        interaction
            .cohesive_zone_length(1.0)
            .is_none_or(|zone| zone >= NCG_MIN_ZONE_SPACINGS * dx)
    }

    /// Solves with a given minimiser.
    pub fn solve_with(
        &mut self,
        minimizer: &dyn Minimizer,
        interaction: Interaction,
        pressure: f64,
        opts: &SolverOptions,
        warm: Option<&Solution>,
    ) -> Result<Solution, ContactError> {
        self.check(interaction, pressure, opts, minimizer.name())?;
        let mut state = match warm {
            Some(w) => {
                let u = w.displacement.as_slice().expect("standard layout");
                if u.len() != self.heights.len() {
                    return Err(ContactError::WarmStart {
                        got: u.len(),
                        want: self.heights.len(),
                    });
                }
                let p = w.pressure.as_slice().expect("standard layout");
                for (field, v) in [("displacement", u), ("pressure", p)] {
                    if let Some((index, &value)) =
                        v.iter().enumerate().find(|(_, x)| !x.is_finite())
                    {
                        return Err(ContactError::WarmStartNonFinite {
                            field,
                            value,
                            index,
                        });
                    }
                }
                State {
                    u: u.to_vec(),
                    p: p.to_vec(),
                }
            }
            None => self.cold_start(interaction, pressure),
        };
        // Loss of symmetry is diagnosed only where there was symmetry to lose (a cold start is
        // uniform, so only a warm start needs checking).
        let symmetric_start = self.symmetric
            && (warm.is_none()
                || inversion_defect(&self.grid, &state.u)
                    <= SYMMETRY_ROUNDING * max_abs(&state.u).max(1.0));
        let t0 = Instant::now();
        let mut stats = minimizer.relax(self, interaction, pressure, opts, &mut state)?;
        // Every result is judged by the same measures, whichever minimiser produced it: the
        // minimiser's own (taken before it cleans up its final state) and an independent
        // evaluation of the state it returns.
        let (violation, force) = if self.free.is_some() {
            free_kernel::residuals(self, pressure, &state)
        } else {
            residuals(self, interaction, pressure, &state.u, opts.tol_gap)
        };
        stats.max_violation = stats.max_violation.max(violation);
        stats.force_residual = stats.force_residual.max(force);
        if !(violation.is_finite() && force.is_finite()) {
            // never a silent number: NaN would pass every `<=` test above as a maximum
            stats.converged = false;
            stats.reason = Some(StopReason::NonFinite);
            stats.max_violation = f64::INFINITY;
            stats.force_residual = f64::INFINITY;
        }
        // Converged means the state meets the tolerance the minimiser stops on, as measured
        // independently: Polonsky–Keer the complementarity of its pressure and gaps, the others
        // the force residual. A state that violates it is never reported converged, however the
        // minimiser stopped (a uniform start once passed as converged after 0 iterations).
        let (measure, value, tol) = if minimizer.name().starts_with("polonsky-keer") {
            let c = complementarity_violation(&self.heights, &state);
            ("constraint violation", c, opts.tol_gap)
        } else {
            ("force residual", force, opts.tol_force)
        };
        if stats.converged && (value > tol || value.is_nan()) {
            stats.converged = false;
            stats.reason = Some(StopReason::Unverified {
                measure,
                value,
                tol,
            });
        }
        if symmetric_start && !stats.converged && stats.reason != Some(StopReason::NonFinite) {
            let defect = inversion_defect(&self.grid, &state.u);
            if defect > SYMMETRY_LOST * max_abs(&state.u).max(1.0) {
                stats.reason = Some(StopReason::LossOfSymmetry { defect });
            }
        }
        stats.wall_s = t0.elapsed().as_secs_f64();
        Ok(self.finish(interaction, pressure, state, stats))
    }

    fn check(
        &self,
        interaction: Interaction,
        pressure: f64,
        opts: &SolverOptions,
        method: &str,
    ) -> Result<(), ContactError> {
        interaction.validate()?;
        opts.validate()?;
        if !pressure.is_finite() {
            return Err(ContactError::parameter(
                "pressure",
                pressure,
                "a finite mean pressure (E* h0/λ)",
            ));
        }
        let adhesive = matches!(interaction, Interaction::Adhesion { gamma0, .. } if gamma0 > 0.0);
        if pressure <= 0.0 && !adhesive {
            return Err(ContactError::parameter(
                "pressure",
                pressure,
                "> 0 without adhesion (under force control a non-positive load has no equilibrium)",
            ));
        }
        let max = pressure_max(opts.tol_gap, self.grid.lx.max(self.grid.ly));
        if pressure.abs() > max {
            return Err(ContactError::Pressure {
                value: pressure,
                allowed: format!(
                    "|p̄| ≤ {max:.3e} for tol_gap = {:?} h0 on this cell: beyond, rounding of the \
                     pressure (ε p̄) alone deflects the surface by more than the tolerance (and \
                     every load above the full-contact pressure gives full contact anyway)",
                    opts.tol_gap
                ),
            });
        }
        if !adhesive && pressure < PRESSURE_MIN {
            return Err(ContactError::Pressure {
                value: pressure,
                allowed: format!(
                    "p̄ ≥ {PRESSURE_MIN:e} without adhesion: below, the solver's squares of \
                     pressures near the smallest double lose all precision, and any such load \
                     already rests on the highest node alone (area 1/N)"
                ),
            });
        }
        if self.free.is_some() && !method.starts_with("polonsky-keer") {
            return Err(ContactError::Parameter {
                name: "method",
                value: method.into(),
                allowed: "\"polonsky-keer\", \"polonsky-keer-plain\" or \"auto\" with the hard wall (the free boundary is solved by Polonsky–Keer only)",
            });
        }
        if method.starts_with("polonsky-keer") && !interaction.is_hard_wall() {
            return Err(ContactError::Parameter {
                name: "method",
                value: method.into(),
                allowed: "\"fire\" or \"auto\" for adhesion and repulsion (Polonsky–Keer solves the hard wall only)",
            });
        }
        Ok(())
    }

    /// Initial state without a warm start: a flat body touching the highest node (hard wall,
    /// adhesion) or resting 3ρ above it, outside the repulsive barrier; uniform pressure.
    fn cold_start(&self, interaction: Interaction, pressure: f64) -> State {
        let lift = match interaction {
            Interaction::Repulsion { rho, .. } => 3.0 * rho,
            _ => 0.0,
        };
        let n = self.heights.len();
        State {
            u: vec![self.h_max + lift; n],
            p: vec![pressure; n],
        }
    }

    fn finish(
        &mut self,
        interaction: Interaction,
        pressure: f64,
        state: State,
        stats: SolveStats,
    ) -> Solution {
        let n = self.heights.len();
        let shape = (self.grid.nx, self.grid.ny);
        let gap: Vec<f64> = state
            .u
            .iter()
            .zip(&self.heights)
            .map(|(u, h)| (u - h).max(0.0))
            .collect();
        let contact = gap.iter().filter(|&&g| g == 0.0).count();
        let mean_u = state.u.iter().sum::<f64>() / n as f64;
        let mean_gap = gap.iter().sum::<f64>() / n as f64;
        let energy = if self.free.is_some() {
            free_kernel::energy(self, pressure, &state.p)
        } else {
            self.energy(interaction, pressure, &state.u, &state.p)
        };
        Solution {
            grid: self.grid,
            interaction,
            mean_pressure: pressure,
            displacement: Array2::from_shape_vec(shape, state.u).expect("shape"),
            gap: Array2::from_shape_vec(shape, gap).expect("shape"),
            pressure: Array2::from_shape_vec(shape, state.p).expect("shape"),
            contact_area: contact as f64 / n as f64,
            mean_gap,
            mean_displacement: mean_u,
            energy,
            stats,
        }
    }

    /// Energy per area: elastic ½⟨(u − ū)(p − p̄)⟩ + load p̄ ū + interaction ⟨γ(g)⟩, using that
    /// the pressure field minus its mean is the elastic stress K u.
    fn energy(&self, interaction: Interaction, pressure: f64, u: &[f64], p: &[f64]) -> f64 {
        let n = u.len() as f64;
        let mean_u = u.iter().sum::<f64>() / n;
        let mean_p = p.iter().sum::<f64>() / n;
        let mut e = 0.0;
        for ((&ui, &pi), &hi) in u.iter().zip(p).zip(&self.heights) {
            e += 0.5 * (ui - mean_u) * (pi - mean_p) + interaction.energy((ui - hi).max(0.0));
        }
        e / n + pressure * mean_u
    }
}

/// The state a minimiser updates: surface heights `u` and the interfacial pressure `p`
/// (row-major, first index x).
pub struct State {
    /// Elastic surface height (h0).
    pub u: Vec<f64>,
    /// Pressure on the body (E* h0/λ).
    pub p: Vec<f64>,
}

/// The hard-wall constraints' largest violation by a state: the gap where the pressure pushes
/// (p > 0 requires g = 0) and the penetration anywhere (g ≥ 0), in h0. What Polonsky–Keer
/// bounds by `tol_gap`, evaluated from the state it returns.
fn complementarity_violation(heights: &[f64], state: &State) -> f64 {
    let mut v = 0.0f64;
    for ((&u, &p), &h) in state.u.iter().zip(&state.p).zip(heights) {
        let g = u - h;
        v = v.max(-g);
        if p > 0.0 {
            v = v.max(g.abs());
        }
    }
    v
}

/// Relative inversion defect up to which a field counts as symmetric (rounding of the sampled
/// cosines and of the transforms stays near 1e-15).
const SYMMETRY_ROUNDING: f64 = 1e-12;
/// Relative inversion defect of an unconverged state beyond which the symmetry is lost: six
/// orders above rounding, far beyond what a stalled but symmetric iteration produces.
const SYMMETRY_LOST: f64 = 1e-6;

fn max_abs(f: &[f64]) -> f64 {
    f.iter().fold(0.0, |m, v| m.max(v.abs()))
}

/// max |f(r) − f(−r)| over `grid`, with −r the node inverted through the origin node.
fn inversion_defect(grid: &Grid, f: &[f64]) -> f64 {
    let (nx, ny) = (grid.nx, grid.ny);
    let mut d = 0.0f64;
    for i in 0..nx {
        let mi = (nx - i) % nx;
        for j in 0..ny {
            let mj = (ny - j) % ny;
            d = d.max((f[i * ny + j] - f[mi * ny + mj]).abs());
        }
    }
    d
}

/// A minimiser of the total energy at fixed mean pressure.
pub trait Minimizer {
    /// Name used in statistics and files.
    fn name(&self) -> &'static str;
    /// Relaxes `state` in place to equilibrium under `pressure`. On return `state.u` and
    /// `state.p` are consistent: `p − mean(p) = K u` and `mean(p) = pressure`.
    fn relax(
        &self,
        model: &mut Model,
        interaction: Interaction,
        pressure: f64,
        opts: &SolverOptions,
        state: &mut State,
    ) -> Result<SolveStats, ContactError>;
}

/// Largest constraint violation and force residual of a state, evaluated the same way for every
/// minimiser: contact nodes are those with g ≤ `contact_tol`.
///
/// - violation: max |g| over nodes carrying positive contact pressure, max(0, −g) elsewhere;
/// - force residual: at a non-contact node, |σ + p̄ + γ'(g)| (must vanish); at a contact node the
///   wall may push but not pull, so max(0, −(σ + p̄ + γ'(g))).
pub fn residuals(
    model: &mut Model,
    interaction: Interaction,
    pressure: f64,
    u: &[f64],
    contact_tol: f64,
) -> (f64, f64) {
    let n = u.len();
    let mut sigma = vec![0.0; n];
    model.kernel.stress(u, &mut sigma);
    let (mut viol, mut force) = (0.0f64, 0.0f64);
    for i in 0..n {
        let g = u[i] - model.heights[i];
        let wall = sigma[i] + pressure + interaction.derivative(g.max(0.0));
        if !(g.is_finite() && wall.is_finite()) {
            return (f64::INFINITY, f64::INFINITY);
        }
        if g <= contact_tol {
            viol = viol.max(-g).max(if wall > 0.0 { g.abs() } else { 0.0 });
            force = force.max(-wall);
        } else {
            force = force.max(wall.abs());
        }
    }
    (viol, force)
}
