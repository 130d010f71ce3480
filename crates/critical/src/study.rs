//! Resolution study: the shift-averaged critical quantities at several grid exponents n, run
//! coarse to fine (each level's solutions warm-start the next, its L_c guesses the next bracket),
//! and extrapolated to zero grid spacing with [`analysis::extrapolate_to_zero`].
//!
//! Grid spacing: `h = sqrt(dx · dy)` in λ (the hexagonal and triangular grids have dx ≠ dy; any
//! fixed measure gives the same v0). Error bars of the extrapolated values combine the fit error
//! (with the shift averages' standard errors as σ when there are several shifts, else the misfit
//! scaled by the reduced χ²) and the largest change when any one resolution is left out — the
//! sensitivity to which n are used (see `analysis::extrapolate`).

use crate::{
    Criterion, CriticalError, CriticalOptions, CriticalResult, Fields, ShiftAverage,
    shifts::{Stat, find_critical_shifted, shift_set},
};
use analysis::{ErrorScale, Extrapolation, Order};
use contact::Solution;
use surface::{Grid, Lattice};

/// Options of [`resolution_study`].
#[derive(Clone, Debug, PartialEq)]
pub struct ResolutionOptions {
    /// Grid exponents, ascending (3..=13).
    pub ns: Vec<u32>,
    /// Shift rule per level: m × m shifts ([`shift_set`]); 0 = the unshifted grid only.
    pub shifts: usize,
    /// Sample the saddle gaps on every shift (else on the first only).
    pub saddle_every_shift: bool,
    /// Per-grid options (the guess is supplied level to level; `keep_fields` is managed here).
    pub critical: CriticalOptions,
    /// Order of the leading error term for contact areas (the perimeter: 1).
    pub area_order: Order,
    /// Order for loads (L_c, p_fc/L_c): fitted by default when there are ≥ 4 levels.
    pub load_order: Order,
}

impl ResolutionOptions {
    /// Options for the given exponents and shifts, default orders: areas first order, loads
    /// first order with fewer than 4 levels and a fitted order otherwise.
    pub fn new(ns: Vec<u32>, shifts: usize) -> Self {
        let load_order = if ns.len() >= 4 {
            Order::Free
        } else {
            Order::Fixed(1.0)
        };
        ResolutionOptions {
            ns,
            shifts,
            saddle_every_shift: false,
            critical: CriticalOptions::default(),
            area_order: Order::Fixed(1.0),
            load_order,
        }
    }
}

/// One level of the study.
#[derive(Clone, Debug)]
pub struct LevelSummary {
    /// Grid exponent.
    pub n: u32,
    /// Grid spacing sqrt(dx dy) (λ).
    pub h: f64,
    /// Shifts used.
    pub shifts: Vec<(f64, f64)>,
    /// Per-shift results (without fields).
    pub results: Vec<CriticalResult>,
    /// Their averages.
    pub average: ShiftAverage,
    /// Wall time of the level (s).
    pub wall_s: f64,
}

impl LevelSummary {
    /// Contact solves (bracket probes and saddle samples) over all shifts.
    pub fn solves(&self) -> usize {
        self.results
            .iter()
            .map(|r| r.probes + r.sample_solves)
            .sum()
    }
    /// Polonsky–Keer iterations over all shifts.
    pub fn iterations(&self) -> usize {
        self.results.iter().map(|r| r.iterations).sum()
    }
}

/// One quantity against grid spacing and its extrapolation.
#[derive(Clone, Debug)]
pub struct Extrapolated {
    /// Name (`l_c`, `a_p_raw`, `a_p_corrected`, `p_fc_over_l_c`, `l_c_subgrid`, with a
    /// `_x`/`_y` suffix for the per-axis transitions).
    pub name: String,
    /// Grid spacings (λ).
    pub h: Vec<f64>,
    /// Shift-averaged values.
    pub v: Vec<f64>,
    /// Their standard errors over shifts (0 with one shift).
    pub sem: Vec<f64>,
    /// The extrapolation, or why it failed.
    pub fit: Result<Extrapolation, String>,
    /// Set when a fitted order was rejected and [`FALLBACK_ORDER`] used instead.
    pub note: Option<String>,
}

/// Order used for loads when a fitted order is unusable (outside [0.5, 4], or its error above
/// half its value): second order, between the fitted orders (≈ 1.7) of the monotone cases and
/// the smooth-quantity default.
pub const FALLBACK_ORDER: f64 = 2.0;

impl Extrapolated {
    /// Extrapolates shift-averaged values `stats` at spacings `h` to zero spacing with the model
    /// `v0 + c h^p` of the given order. A fitted order ([`Order::Free`]) outside [0.5, 4] or with
    /// an error above half its value (non-monotone convergence) is replaced by
    /// [`FALLBACK_ORDER`], with a note. The standard errors over shifts are the σ of the fit when
    /// all are positive (several shifts), else the misfit sets the error scale.
    pub fn new(name: &str, h: &[f64], stats: &[Stat], order: Order) -> Self {
        let v: Vec<f64> = stats.iter().map(|s| s.mean).collect();
        let sem: Vec<f64> = stats.iter().map(|s| s.sem).collect();
        let sigma = sem.iter().all(|s| *s > 0.0).then_some(sem.as_slice());
        let run = |o: Order| {
            analysis::extrapolate_to_zero(h, &v, sigma, o, ErrorScale::Auto)
                .map_err(|e| e.to_string())
        };
        let mut note = None;
        let mut fit = run(order);
        if order == Order::Free {
            // A fitted order is only meaningful for monotone convergence; otherwise fall back.
            let bad = match &fit {
                Ok(f) => {
                    !(0.5..=4.0).contains(&f.order)
                        || f.order_error.is_nan()
                        || f.order_error > 0.5 * f.order
                }
                Err(_) => true,
            };
            if bad {
                note = Some(format!(
                    "fitted order unusable ({}): convergence is not monotone in the asymptotic \
                     range; fell back to a fixed order {FALLBACK_ORDER}",
                    match &fit {
                        Ok(f) => format!("p = {:.2} ± {:.2}", f.order, f.order_error),
                        Err(e) => e.clone(),
                    }
                ));
                fit = run(Order::Fixed(FALLBACK_ORDER));
            }
        }
        Extrapolated {
            name: name.to_string(),
            h: h.to_vec(),
            v,
            sem,
            fit,
            note,
        }
    }

    /// `(v0, error)` if the extrapolation succeeded.
    pub fn value(&self) -> Option<(f64, f64)> {
        self.fit.as_ref().ok().map(|f| (f.v0, f.v0_error))
    }
}

/// Result of [`resolution_study`].
#[derive(Clone, Debug)]
pub struct ResolutionStudy {
    /// Model.
    pub lattice: Lattice,
    /// Levels, coarse to fine.
    pub levels: Vec<LevelSummary>,
    /// Extrapolations: `l_c`, `a_p_raw`, `a_p_corrected`, `p_fc_over_l_c` (of the `any`
    /// transition), their `_x`/`_y` variants for L_c and a_p, and `l_c_subgrid` if available.
    pub extrapolations: Vec<Extrapolated>,
    /// Continuum full-contact pressure π t̄ (E* h0/λ).
    pub p_fc_exact: f64,
    /// Fields at the `any` bracket ends on the finest grid, first shift (for maps).
    pub fields: Option<Fields>,
    /// Wall time (s).
    pub wall_s: f64,
}

impl ResolutionStudy {
    /// The extrapolation called `name`.
    pub fn get(&self, name: &str) -> Option<&Extrapolated> {
        self.extrapolations.iter().find(|e| e.name == name)
    }

    /// p_fc (continuum) / L_c (extrapolated) and its error.
    pub fn p_fc_over_l_c(&self) -> Option<(f64, f64)> {
        let (l, e) = self.get("l_c")?.value()?;
        let r = self.p_fc_exact / l;
        Some((r, r * e / l))
    }
}

/// Runs the study (see the module docs). Levels run in order; shifts within a level in parallel.
pub fn resolution_study(
    lattice: Lattice,
    opts: &ResolutionOptions,
) -> Result<ResolutionStudy, CriticalError> {
    resolution_study_with(lattice, opts, &mut |_| {})
}

/// [`resolution_study`], calling `done` after each level (e.g. for progress reports).
pub fn resolution_study_with(
    lattice: Lattice,
    opts: &ResolutionOptions,
    done: &mut dyn FnMut(&LevelSummary),
) -> Result<ResolutionStudy, CriticalError> {
    let t0 = std::time::Instant::now();
    if opts.ns.is_empty() || opts.ns.windows(2).any(|w| w[1] <= w[0]) {
        return Err(CriticalError::Parameter {
            name: "ns",
            value: format!("{:?}", opts.ns),
            allowed: "a non-empty, strictly ascending list of grid exponents",
        });
    }
    let shifts = shift_set(opts.shifts);
    let mut levels: Vec<LevelSummary> = Vec::new();
    let mut warm: Option<Vec<Solution>> = None;
    let mut fields = None;
    for (k, &n) in opts.ns.iter().enumerate() {
        let mut co = opts.critical.clone();
        co.keep_fields = true;
        let guesses: Option<Vec<f64>> = levels
            .last()
            .map(|l| l.results.iter().map(|r| r.l_c()).collect());
        if k >= 2 {
            let a = levels[k - 1].average.any.l_c.mean;
            let b = levels[k - 2].average.any.l_c.mean;
            co.guess_width = (3.0 * (a - b).abs() / a).clamp(1e-5, 0.02);
        }
        let mut study = find_critical_shifted(
            lattice,
            n,
            &shifts,
            &co,
            warm.as_deref(),
            guesses.as_deref(),
            opts.saddle_every_shift,
        )?;
        let mut next_warm = Vec::new();
        for (i, r) in study.results.iter_mut().enumerate() {
            let f = r.fields.take().expect("kept");
            if i == 0 && k + 1 == opts.ns.len() {
                fields = Some(f.clone());
            }
            next_warm.push(f.below);
        }
        warm = Some(next_warm);
        let g = Grid::new(lattice, n).map_err(|e| CriticalError::Surface(e.to_string()))?;
        levels.push(LevelSummary {
            n,
            h: (g.dx() * g.dy()).sqrt(),
            shifts: shifts.clone(),
            average: study.average,
            results: study.results,
            wall_s: study.wall_s,
        });
        done(levels.last().expect("pushed"));
    }

    let h: Vec<f64> = levels.iter().map(|l| l.h).collect();
    let mut ex = Vec::new();
    for c in Criterion::ALL {
        let suffix = match c {
            Criterion::Any => "",
            Criterion::X => "_x",
            Criterion::Y => "_y",
        };
        let t = |f: &dyn Fn(&crate::shifts::TransitionAverage) -> Stat| {
            levels
                .iter()
                .map(|l| f(l.average.transition(c)))
                .collect::<Vec<_>>()
        };
        ex.push(Extrapolated::new(
            &format!("l_c{suffix}"),
            &h,
            &t(&|a| a.l_c),
            opts.load_order,
        ));
        ex.push(Extrapolated::new(
            &format!("a_p_raw{suffix}"),
            &h,
            &t(&|a| a.a_p_raw),
            opts.area_order,
        ));
        ex.push(Extrapolated::new(
            &format!("a_p_corrected{suffix}"),
            &h,
            &t(&|a| a.a_p_corrected),
            opts.area_order,
        ));
    }
    let ratio: Vec<Stat> = levels.iter().map(|l| l.average.p_fc_over_l_c).collect();
    ex.push(Extrapolated::new(
        "p_fc_over_l_c",
        &h,
        &ratio,
        opts.load_order,
    ));
    let sub: Option<Vec<Stat>> = levels.iter().map(|l| l.average.l_c_subgrid).collect();
    if let Some(sub) = sub {
        ex.push(Extrapolated::new("l_c_subgrid", &h, &sub, opts.load_order));
    }
    Ok(ResolutionStudy {
        lattice,
        levels,
        extrapolations: ex,
        p_fc_exact: lattice.exact().p_fc,
        fields,
        wall_s: t0.elapsed().as_secs_f64(),
    })
}
