//! The critical load L_c and the contact area a_p at the percolation threshold of the hard-wall
//! contact of the three single-wavelength models (Dapp & Müser 2015; PHYSICS.md, "Percolation,
//! critical load, near-critical scaling").
//!
//! Units: E* = 1, λ = 1, h0 = 1. The load L is the mean pressure p̄ (E* h0/λ), so p_fc/L_c is a
//! ratio of pressures.
//!
//! # The criterion
//! On a grid, contact is the set of nodes with zero gap (the Polonsky–Keer solver sets g = 0
//! exactly where it carries pressure), labelled 8-connected; the fluid is the rest, labelled
//! 4-connected. With this dual pair, along each axis exactly one holds: the fluid wraps along it
//! or the contact cuts across it ([`FlowState`], checked on every probe). Three transitions are
//! bracketed ([`Criterion`]):
//! - `x`, `y`: the load above which the contact blocks flow along that axis;
//! - `any`: the load above which the fluid percolates along *no* axis — the paper's L_c, "the
//!   fluid region stops percolating". It is the larger of the two axis transitions.
//!
//! Why both axes: in the continuum every saddle of a model is equivalent (the square model's two
//! saddles by the 90° rotation, the six of the hexagonal and triangular cells by the 60°
//! rotations), so all channels close at one load and the three transitions coincide. A grid
//! breaks these symmetries (the hexagonal cell's grid has dx ≠ dy, shifts break x ↔ y), so the
//! channel orientations close at slightly different loads; which orientation decides which axis
//! follows from the geometry: for the square model the saddles with channels along x block x and
//! those along y block y; for the hexagonal and triangular models the channels along y (saddles at
//! (λ/√3, 0)) block y, while x is blocked only when both families of diagonal channels (±30° from
//! x) are closed — one diagonal family alone leaves contact chains with winding (1, ±2) that
//! block neither axis. Rather than encoding this, the search labels clusters and asks the
//! question directly, for each axis and for both; the difference between the three brackets on
//! one grid measures the anisotropy of the discretisation and vanishes with the grid spacing.
//!
//! # What one grid gives ([`find_critical`])
//! - the three brackets, each probed at both ends, to a relative width ≤ `rel_width` (1e-9 by
//!   default; resolvable because the solver tolerance is finer — see [`CriticalOptions::tol_gap`]);
//! - a_p at each transition: raw and perimeter-corrected contact area, the mean of the two
//!   bracket ends (they differ by the few bridging nodes; the difference is reported);
//! - p_fc of the sampled surface and p_fc/L_c;
//! - the sub-grid estimate ([`saddle`]): saddle gaps sampled at loads below L_c and fitted by
//!   `A (L_c − L)^ζ` with L_c free.
//!
//! # Near-critical scaling
//! [`ladder`] solves at reduced loads around L_c and keeps a window around one saddle;
//! [`scaling`] measures the channel's width and length there and fits the exponents;
//! [`running`] turns the rungs into running exponents with grid errors.
//!
//! # Beyond one grid
//! [`shifts`] averages over sub-grid shifts of the surface relative to the grid; [`study`] runs
//! several grid exponents n, coarse to fine with warm starts, and extrapolates to zero spacing.

pub mod bracket;
pub mod constriction;
pub mod ladder;
pub mod leakage;
pub mod neck_moments;
pub mod refined;
pub mod refined_flow;
pub mod running;
pub mod saddle;
pub mod scaling;
pub mod shifts;
mod state;
pub mod study;
pub mod warm;
pub mod window_flow;

pub use bracket::{Bracket, Criterion, Prober, SearchOptions, bracket_transitions};
pub use saddle::{SaddleFit, SaddleGroup, SaddleSample, Subgrid};
pub use shifts::{
    ShiftAverage, ShiftStudy, Stat, TransitionAverage, find_critical_shifted, shift_set,
};
pub use state::{FlowState, axis_name, contact_mask};
pub use study::{
    Extrapolated, FALLBACK_ORDER, LevelSummary, ResolutionOptions, ResolutionStudy,
    resolution_study, resolution_study_with,
};

use contact::{Interaction, Method, Model, Solution, SolverOptions};
use percolation::ContactArea;
use std::time::Instant;
use surface::{Grid, Lattice, Surface};

/// Errors of the critical-load search.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CriticalError {
    /// A parameter outside its allowed range.
    #[error("invalid {name} = {value}: allowed {allowed}")]
    Parameter {
        /// Name.
        name: &'static str,
        /// Value as given.
        value: String,
        /// Allowed range in words.
        allowed: &'static str,
    },
    /// Surface construction failed.
    #[error("surface: {0}")]
    Surface(String),
    /// The contact solver failed or did not converge.
    #[error("contact solve at load {load}: {detail}")]
    Solver {
        /// Load (E* h0/λ).
        load: f64,
        /// What went wrong.
        detail: String,
    },
    /// Both or neither of "fluid wraps" and "contact cuts" along one axis: a broken invariant.
    #[error(
        "dual-connectivity rule violated along {axis}: fluid wraps = {fluid}, contact blocks = {blocked} \
         (exactly one must hold; this is a bug in the cluster labelling)"
    )]
    DualRule {
        /// Axis name.
        axis: &'static str,
        /// Fluid wraps along it.
        fluid: bool,
        /// Contact cuts it.
        blocked: bool,
    },
    /// No load in the allowed range is on one side of a transition.
    #[error("cannot bracket the transition {side} load {load}: {detail}")]
    NoBracket {
        /// "below" or "above".
        side: &'static str,
        /// The last load tried (E* h0/λ).
        load: f64,
        /// Details.
        detail: String,
    },
    /// Percolation was found non-monotone in load.
    #[error(
        "percolation is not monotone in load for criterion `{criterion}`: the fluid percolates at {open_at} \
         but was blocked at {blocked_at}; tighten tol_gap (the contact sets of nearby loads differ by \
         nodes within the tolerance of closing)"
    )]
    NonMonotone {
        /// Criterion name.
        criterion: &'static str,
        /// Load with the fluid percolating.
        open_at: f64,
        /// Lower load with it blocked.
        blocked_at: f64,
    },
    /// The probe budget ran out.
    #[error("no bracket within {probes} probes ({summary}); raise max_probes or loosen rel_width")]
    TooManyProbes {
        /// Probes used.
        probes: usize,
        /// State of the brackets.
        summary: String,
    },
}

impl CriticalError {
    pub(crate) fn param(name: &'static str, value: f64, allowed: &'static str) -> Self {
        CriticalError::Parameter {
            name,
            value: format!("{value:?}"),
            allowed,
        }
    }
}

/// Options of [`find_critical`].
#[derive(Clone, Debug, PartialEq)]
pub struct CriticalOptions {
    /// Polonsky–Keer tolerance on the constraint violation (h0). It sets how finely the transition
    /// can be resolved: a node enters the contact set when its penetration exceeds this, so the
    /// grid's L_c is defined to about `tol_gap / (L dg/dL)` in relative terms (dg/dL of the
    /// bridging node is 0.1–1 h0 per E* h0/λ). Default 1e-10, the contact solver's default: finer
    /// tolerances stagnate on 2^9 grids and beyond.
    pub tol_gap: f64,
    /// Iteration cap per solve.
    pub max_iter: usize,
    /// Target relative width `(hi − lo)/hi` of each bracket. Default 1e-9.
    pub rel_width: f64,
    /// First load probed (E* h0/λ). `None`: a coarse search on the grid 2^(n−2) (recursively;
    /// at n ≤ 5 the guess 0.3 p_fc and wide expansions) supplies the guess and a warm start.
    pub guess: Option<f64>,
    /// Relative step of the first bracket expansion around the guess. Default 0.01.
    pub guess_width: f64,
    /// Reduced loads l = (L − L_c)/L_c < 0 at which the saddle gaps are sampled for the sub-grid
    /// estimate (relative to the grid's `any` transition). Empty: no sub-grid estimate.
    pub saddle_loads: Vec<f64>,
    /// Keep the solutions at the ends of the `any` bracket (for maps and warm starts).
    pub keep_fields: bool,
    /// Cap on probes per search.
    pub max_probes: usize,
}

impl Default for CriticalOptions {
    fn default() -> Self {
        CriticalOptions {
            tol_gap: 1e-10,
            max_iter: 200_000,
            rel_width: 1e-9,
            guess: None,
            guess_width: 0.01,
            saddle_loads: default_saddle_loads(),
            keep_fields: false,
            max_probes: 400,
        }
    }
}

/// Reduced loads of the saddle-gap samples: six values, logarithmically spaced from −0.02 to
/// −0.002 (the span of the paper's load ladder). The smallest |l| needs the channel resolved by
/// a few nodes: about n ≥ 8 for the square model, n ≥ 9 for the hexagonal one; samples whose
/// interpolation stencil touches contact are dropped, and groups with fewer than four open
/// samples are not fitted.
pub fn default_saddle_loads() -> Vec<f64> {
    (0..6)
        .map(|k| -0.02 * 0.1f64.powf(k as f64 / 5.0))
        .collect()
}

impl CriticalOptions {
    /// Checks the options.
    pub fn validate(&self) -> Result<(), CriticalError> {
        // the contact solver's bound (contact::TOL_GAP_MAX): checked here so that a tolerance
        // as large as the gaps is refused as such, not blamed later on the percolation search
        if !(self.tol_gap > 0.0 && self.tol_gap <= contact::TOL_GAP_MAX) {
            return Err(CriticalError::param(
                "tol_gap",
                self.tol_gap,
                "0 < tol_gap ≤ 1e-3 (h0; contact::TOL_GAP_MAX)",
            ));
        }
        if !(self.rel_width.is_finite() && self.rel_width > 0.0 && self.rel_width < 1.0) {
            return Err(CriticalError::param(
                "rel_width",
                self.rel_width,
                "in (0, 1) (relative bracket width)",
            ));
        }
        if let Some(g) = self.guess
            && !(g.is_finite() && g > 0.0)
        {
            return Err(CriticalError::param("guess", g, "finite and > 0 (E* h0/λ)"));
        }
        if !(self.guess_width.is_finite() && self.guess_width > 0.0) {
            return Err(CriticalError::param(
                "guess_width",
                self.guess_width,
                "finite and > 0",
            ));
        }
        if let Some(&l) = self
            .saddle_loads
            .iter()
            .find(|l| !(l.is_finite() && **l < 0.0 && **l > -1.0))
        {
            return Err(CriticalError::param(
                "saddle_loads",
                l,
                "reduced loads in (−1, 0)",
            ));
        }
        Ok(())
    }
}

/// One transition located on one grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Transition {
    /// The bracket (loads in E* h0/λ).
    pub bracket: Bracket,
    /// Contact area at `bracket.lo` (fluid percolating).
    pub area_lo: ContactArea,
    /// Contact area at `bracket.hi` (blocked).
    pub area_hi: ContactArea,
}

impl Transition {
    /// The critical load: the bracket's midpoint (E* h0/λ).
    pub fn l_c(&self) -> f64 {
        self.bracket.mid()
    }
    /// Raw contact fraction at L_c: mean of the bracket ends.
    pub fn a_p_raw(&self) -> f64 {
        0.5 * (self.area_lo.raw + self.area_hi.raw)
    }
    /// Perimeter-corrected contact fraction at L_c: mean of the bracket ends.
    pub fn a_p_corrected(&self) -> f64 {
        0.5 * (self.area_lo.corrected + self.area_hi.corrected)
    }
    /// Nodes that closed across the bracket (the bridging nodes).
    pub fn bridging_nodes(&self) -> isize {
        self.area_hi.n_contact as isize - self.area_lo.n_contact as isize
    }
}

/// The solutions at the ends of the `any` bracket.
#[derive(Clone, Debug)]
pub struct Fields {
    /// Just below L_c: the fluid still percolates.
    pub below: Solution,
    /// Just above L_c: blocked along both axes.
    pub above: Solution,
}

/// Everything [`find_critical`] finds on one grid.
#[derive(Clone, Debug)]
pub struct CriticalResult {
    /// Model.
    pub lattice: Lattice,
    /// Grid exponent n (2^n × 2^n nodes).
    pub n: u32,
    /// The grid (with its sub-grid shift).
    pub grid: Grid,
    /// Full-contact pressure of the sampled surface (E* h0/λ).
    pub p_fc: f64,
    /// The `any` transition: the fluid stops percolating altogether (the paper's L_c).
    pub any: Transition,
    /// Flow along x blocked.
    pub x: Transition,
    /// Flow along y blocked.
    pub y: Transition,
    /// Saddle groups (by channel orientation).
    pub groups: Vec<SaddleGroup>,
    /// Saddle-gap samples below L_c.
    pub samples: Vec<SaddleSample>,
    /// The sub-grid fit, if enough samples were open.
    pub subgrid: Option<Subgrid>,
    /// Why groups could not be fitted.
    pub notes: Vec<String>,
    /// Contact solves in the bracket search.
    pub probes: usize,
    /// Contact solves for the saddle samples.
    pub sample_solves: usize,
    /// Polonsky–Keer iterations over all solves (each about one FFT pair).
    pub iterations: usize,
    /// Solves repeated from another start because the first did not converge.
    pub retries: usize,
    /// Wall time (s), including any coarse pre-search.
    pub wall_s: f64,
    /// Fields at the `any` bracket ends, if requested.
    pub fields: Option<Fields>,
}

impl CriticalResult {
    /// L_c of the `any` transition (E* h0/λ).
    pub fn l_c(&self) -> f64 {
        self.any.l_c()
    }
    /// p_fc / L_c.
    pub fn p_fc_over_l_c(&self) -> f64 {
        self.p_fc / self.l_c()
    }
    /// The transition of a criterion.
    pub fn transition(&self, c: Criterion) -> &Transition {
        match c {
            Criterion::Any => &self.any,
            Criterion::X => &self.x,
            Criterion::Y => &self.y,
        }
    }
}

/// Solves and keeps solutions for warm starts.
struct SolveProber<'a> {
    model: Model,
    opts: SolverOptions,
    store: Vec<(f64, Solution)>,
    initial: Option<&'a Solution>,
    iterations: usize,
    retries: usize,
}

impl SolveProber<'_> {
    /// Warm start for `load`: between two stored solutions, their pressures interpolated
    /// linearly in load (exact while the contact set does not change, since the hard-wall
    /// solution is affine in the load on a fixed contact set); otherwise the nearest stored
    /// solution, or the initial one.
    fn warm_for<'s>(
        store: &'s [(f64, Solution)],
        initial: Option<&'s Solution>,
        load: f64,
    ) -> Option<std::borrow::Cow<'s, Solution>> {
        use std::borrow::Cow;
        let below = store
            .iter()
            .filter(|(l, _)| *l < load)
            .max_by(|a, b| a.0.total_cmp(&b.0));
        let above = store
            .iter()
            .filter(|(l, _)| *l > load)
            .min_by(|a, b| a.0.total_cmp(&b.0));
        match (below, above) {
            (Some((la, a)), Some((lb, b))) => {
                let t = (load - la) / (lb - la);
                let mut w = a.clone();
                w.pressure
                    .zip_mut_with(&b.pressure, |p, q| *p += t * (q - *p));
                Some(Cow::Owned(w))
            }
            (Some((_, a)), None) | (None, Some((_, a))) => Some(Cow::Borrowed(a)),
            (None, None) => initial.map(Cow::Borrowed),
        }
    }

    /// Solves at `load` from the interpolated or nearest warm start ([`Self::warm_for`]).
    fn solve(&mut self, load: f64) -> Result<Solution, CriticalError> {
        let first = Self::warm_for(&self.store, self.initial, load).map(|w| w.into_owned());
        self.solve_from(load, first)
    }

    /// Solves at `load` from `first`, and, if the solver does not converge from it, again from
    /// the nearest stored solution and then from a cold start (counted in `retries`).
    fn solve_from(
        &mut self,
        load: f64,
        first: Option<Solution>,
    ) -> Result<Solution, CriticalError> {
        let (sol, iterations, retries) =
            solve_with_retries(&mut self.model, &self.opts, load, first, &self.store)?;
        self.iterations += iterations;
        self.retries += retries;
        Ok(sol)
    }

    fn get(&self, load: f64) -> &Solution {
        &self
            .store
            .iter()
            .find(|(l, _)| *l == load)
            .expect("bracket ends are kept")
            .1
    }
}

impl Prober for SolveProber<'_> {
    fn probe(&mut self, load: f64) -> Result<FlowState, CriticalError> {
        let sol = self.solve(load)?;
        let state = FlowState::of_gap(sol.gap.view())?;
        self.store.push((load, sol));
        Ok(state)
    }
    fn keep(&mut self, loads: &[f64]) {
        self.store.retain(|(l, _)| loads.contains(l));
    }
}

/// Locates the percolation transitions of the hard-wall contact of `surface` (see the crate
/// docs), with the sub-grid estimate if `opts.saddle_loads` is not empty. `warm`: a solution near
/// L_c on any grid of the same cell (prolonged onto this one) for the first probe.
pub fn find_critical(
    surface: &Surface,
    opts: &CriticalOptions,
    warm: Option<&Solution>,
) -> Result<CriticalResult, CriticalError> {
    opts.validate()?;
    let t0 = Instant::now();
    let grid = surface.grid;
    let n = grid.nx.trailing_zeros();
    let p_fc = surface.p_fc_grid();

    // Guess and warm start: given, or from a coarse search.
    let mut coarse_iterations = 0usize;
    let (guess, coarse_warm): (f64, Option<Solution>) = match opts.guess {
        Some(g) => (g, warm.map(|w| warm::warm_start_from(w, &grid))),
        None if n > 5 && warm.is_none() => {
            let cg = Grid::new(surface.lattice, n - 2)
                .and_then(|g| g.shifted(grid.shift.0, grid.shift.1))
                .map_err(|e| CriticalError::Surface(e.to_string()))?;
            let cs = Surface::on_grid(surface.lattice, cg);
            let co = CriticalOptions {
                rel_width: 1e-4,
                saddle_loads: Vec::new(),
                keep_fields: true,
                guess: None,
                ..opts.clone()
            };
            let c = find_critical(&cs, &co, None)?;
            coarse_iterations = c.iterations;
            let f = c.fields.expect("kept");
            (c.any.l_c(), Some(warm::warm_start_from(&f.below, &grid)))
        }
        None => match warm {
            Some(w) => (w.mean_pressure, Some(warm::warm_start_from(w, &grid))),
            None => (0.3 * p_fc, None),
        },
    };
    let guess_width = if opts.guess.is_none() && coarse_warm.is_none() {
        0.5
    } else {
        opts.guess_width
    };

    let model = Model::new(surface).map_err(|e| CriticalError::Solver {
        load: f64::NAN,
        detail: e.to_string(),
    })?;
    let mut prober = SolveProber {
        model,
        opts: SolverOptions {
            tol_gap: opts.tol_gap,
            max_iter: opts.max_iter,
            method: Method::PolonskyKeer,
            ..Default::default()
        },
        store: Vec::new(),
        initial: coarse_warm.as_ref(),
        iterations: coarse_iterations,
        retries: 0,
    };
    let search = SearchOptions {
        guess: guess.clamp(1e-6 * p_fc, p_fc),
        guess_width,
        rel_width: opts.rel_width,
        load_min: 1e-6 * p_fc,
        load_max: p_fc * (1.0 + 1e-6),
        max_probes: opts.max_probes,
    };
    let (brackets, probes) = bracket_transitions(&mut prober, &search)?;
    let area = |load: f64, p: &SolveProber| {
        percolation::contact_area(contact_mask(p.get(load).gap.view()).view())
    };
    let [any, x, y] = brackets.map(|b| Transition {
        area_lo: area(b.lo, &prober),
        area_hi: area(b.hi, &prober),
        bracket: b,
    });

    // Saddle-gap samples below L_c, walking down from the `any` bracket's lower end.
    let groups = saddle::saddle_groups(surface);
    let mut samples = Vec::new();
    let mut loads: Vec<f64> = opts.saddle_loads.clone();
    loads.sort_by(|a, b| b.total_cmp(a)); // closest to L_c first
    let l_c = any.l_c();
    let mut prev: Option<Solution> = None;
    for &l in &loads {
        let load = l_c * (1.0 + l);
        let start = match prev.take() {
            Some(p) => p,
            None => prober.get(any.bracket.lo).clone(),
        };
        let sol = prober.solve_from(load, Some(start))?;
        let gap = saddle::sample_groups(surface, &groups, sol.displacement.view(), sol.gap.view());
        samples.push(SaddleSample {
            load,
            reduced: l,
            gap,
            area: sol.contact_area,
        });
        prev = Some(sol);
    }
    let (subgrid, notes) = if samples.is_empty() {
        (None, Vec::new())
    } else {
        saddle::fit_subgrid(&groups, &samples)
    };

    let fields = opts.keep_fields.then(|| Fields {
        below: prober.get(any.bracket.lo).clone(),
        above: prober.get(any.bracket.hi).clone(),
    });
    Ok(CriticalResult {
        lattice: surface.lattice,
        n,
        grid,
        p_fc,
        any,
        x,
        y,
        groups,
        sample_solves: samples.len(),
        samples,
        subgrid,
        notes,
        probes,
        iterations: prober.iterations,
        retries: prober.retries,
        wall_s: t0.elapsed().as_secs_f64(),
        fields,
    })
}

/// The hard-wall solve at `load` from `first`; if it does not converge, again from the solution
/// in `store` nearest in load and then from a cold start. Returns the solution, the iterations
/// spent and the number of retries; the error names the load and the last failure.
pub(crate) fn solve_with_retries(
    model: &mut Model,
    opts: &SolverOptions,
    load: f64,
    first: Option<Solution>,
    store: &[(f64, Solution)],
) -> Result<(Solution, usize, usize), CriticalError> {
    let nearest = || {
        store
            .iter()
            .min_by(|a, b| (a.0 - load).abs().total_cmp(&(b.0 - load).abs()))
            .map(|(_, s)| s.clone())
    };
    let (mut iterations, mut retries) = (0, 0);
    let mut last = String::new();
    let mut first = Some(first);
    for attempt in 0..3 {
        let start: Option<Solution> = match attempt {
            0 => first.take().flatten(),
            1 => nearest(),
            _ => None,
        };
        if attempt == 1 && start.is_none() {
            continue;
        }
        let sol = model
            .solve(Interaction::HardWall, load, opts, start.as_ref())
            .map_err(|e| CriticalError::Solver {
                load,
                detail: e.to_string(),
            })?;
        iterations += sol.stats.iterations;
        if sol.stats.converged {
            return Ok((sol, iterations, retries));
        }
        retries += 1;
        last = format!(
            "not converged after {} iterations (violation {:.3e} > tol_gap {:.1e}): {}",
            sol.stats.iterations,
            sol.stats.max_violation,
            opts.tol_gap,
            sol.stats
                .reason
                .as_ref()
                .map(|r| r.to_string())
                .unwrap_or_default()
        );
    }
    Err(CriticalError::Solver {
        load,
        detail: format!("{last} (also from the nearest solution and from a cold start)"),
    })
}
