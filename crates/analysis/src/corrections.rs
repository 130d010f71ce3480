//! Corrections to scaling: asymptotic exponents of `y = A |l|^x (1 + B |l|^ω)` as l → 0, with an
//! error bar that includes the choice of fit range and fit form.
//!
//! # Input and units
//! A ladder of [`ScalingPoint`]s `(l, y, σ_y)` on one side of L_c (see [`crate::running`]),
//! grid-converged: rungs beyond a flagged running exponent must be left out first
//! ([`crate::grid_converged_rungs`]); the fits here know nothing about resolution. Only
//! |l| enters the fits. With every σ_y > 0 the fits are weighted (log space: σ_ln y = σ_y/y) and
//! the errors are the covariance's, scaled up by sqrt(χ²/dof) when the misfit exceeds the σ
//! (never down); with any σ_y = 0 the fits are unweighted and the errors scaled by the reduced χ²
//! (the misfit is the noise: the right choice for noise-free simulation data).
//!
//! # The two forms ([`Form`]), each with ω free or fixed ([`Omega`])
//! - [`Form::Direct`]: `ln y = ln A + x ln|l| + ln(1 + B|l|^ω)` (MPFIT; exact model).
//!   Starting values: for ω on a grid over the allowed range the linearised model
//!   `ln y ≈ ln A + x ln|l| + B|l|^ω` is solved by linear least squares; the best becomes the start.
//! - [`Form::Running`]: the local slopes of neighbouring rungs ([`crate::local_slopes`]) against
//!   `u_ω` ([`crate::RunningSlope::u_omega`]): `x_eff = x + ωB u_ω` — linear for fixed ω, exact to
//!   first order in B (the O(B²|l|^2ω) remainder is what makes this form differ from the direct
//!   one). Its statistical error treats neighbouring slopes as independent although they share a
//!   rung, so it is only indicative; its *value* enters the estimate through the form spread.
//! - [`Form::Origin`] (only with [`AsymptoticOptions::origin`]): the direct form with the load
//!   origin free, `ln y = ln A + x ln(|l| + δ) + ln(1 + B|l|^ω)`, ω held at the fixed ω, δ within
//!   ±[`AsymptoticOptions::origin_bound`] of the window's smallest |l| (fitted as δ/|l|_min, so
//!   that the solver sees a parameter of order one). It nests the direct fixed-ω fit (δ = 0), so
//!   it can only fit better; what it measures is how far x moves when the power law's origin is
//!   not taken to be exactly L_c. Why: a ladder's reduced load is measured from the closing load
//!   of its own discretisation, and a shift of the origin by δ adds −x δ (1/|l_lo| − 1/|l_hi|)/
//!   ln(l_hi/l_lo) to a running exponent: a drift growing as 1/|l| near L_c, which a correction
//!   |l|^ω with ω > 0 cannot mimic (docs/near-critical.md §5t: the hexagonal window change at
//!   k = 6 is such a shift, a few 1e-8 of L_c). Never the reference; its x enters the spread.
//!
//! # The asymptotic estimate ([`asymptotic_estimate`])
//! Windows: the full ladder, then the ladder with its largest |l| dropped, then the two largest,
//! … (the correction term is largest far from L_c, so dropping those tests whether it is
//! captured). On every window each form is fitted with ω free and with ω fixed (at
//! [`AsymptoticOptions::omega_fixed`], or else at the ω of the direct free fit on the widest window
//! that constrains it). A fit is **accepted** only if it constrains what it claims
//! ([`WindowIssue`]): at least `min_dof` degrees of freedom, a |l| range of at least
//! `min_decades`, a converged fit with a finite error, and, with ω free, ω not at a bound and
//! `σ_ω ≤ max_omega_rel_error · ω`. Rejected fits are reported with the reason.
//!
//! The reference fit is the first accepted one on the widest window, in the order direct/free,
//! direct/fixed, running/fixed, running/free. The estimate is its x, with
//! `error = sqrt(σ_stat² + spread²)`, `spread = max |x_v − x_ref|` over all accepted fits v (the
//! range spread and the form spread are also reported separately). The maximum rather than a
//! standard deviation is deliberate: the variants are few and not independent, and a
//! conservative bound is the honest choice. With [`AsymptoticOptions::origin`] each window also
//! gets the origin fit (after the four, at the fixed ω); it is never the reference, its x enters
//! `spread` (and `form_spread` on the reference's window), and its own largest change is
//! reported as `origin_spread`. With one accepted fit the spread is not measured
//! ([`AsymptoticEstimate::spread_measured`] false) and the error is the statistical one alone.
//!
//! Cost: per window 4 small fits (≤ 4 parameters, ≤ ~20 points): microseconds to milliseconds.

use crate::error::{FitError, Result, check_arg};
use crate::fit::{ErrorScale, FitResult};
use crate::linear::linear_least_squares;
use crate::nonlinear::{NonlinearOptions, ParamSpec, nonlinear_fit};
use crate::running::{RunningSlope, ScalingPoint, local_slopes};

/// The fit form.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Form {
    /// `y = A|l|^x (1 + B|l|^ω)` fitted to the rungs.
    Direct,
    /// `x_eff = x + ωB u_ω` fitted to the running exponents.
    Running,
    /// `y = A(|l| + δ)^x (1 + B|l|^ω)`, ω held, fitted to the rungs (the load origin free).
    Origin,
}

/// The correction exponent: fitted or held.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Omega {
    /// Fitted within the options' bounds.
    Free,
    /// Held at this value (> 0).
    Fixed(f64),
}

/// Options of the corrected fits and of [`asymptotic_estimate`].
#[derive(Clone, Debug, PartialEq)]
pub struct AsymptoticOptions {
    /// Bounds of a free ω. Default (0.05, 3).
    pub omega_bounds: (f64, f64),
    /// ω of the fixed-ω fits; `None`: from the direct free fit (module docs).
    pub omega_fixed: Option<f64>,
    /// Least degrees of freedom of an accepted fit. Default 1.
    pub min_dof: usize,
    /// Least log10(|l|_max/|l|_min) of an accepted window. Default 1 (one decade).
    pub min_decades: f64,
    /// Largest σ_ω/ω of an accepted free-ω fit. Default 0.5.
    pub max_omega_rel_error: f64,
    /// Most rungs dropped from the large-|l| end (the loop also stops when too few remain).
    pub max_dropped: usize,
    /// Also fit [`Form::Origin`] on every window (its x enters the spread). Default false.
    pub origin: bool,
    /// Largest |δ| of an origin fit, as a fraction of the window's smallest |l|; a fit that
    /// ends at the bound is rejected ([`WindowIssue::OriginUnconstrained`]). Default 0.5.
    pub origin_bound: f64,
}

impl Default for AsymptoticOptions {
    fn default() -> Self {
        AsymptoticOptions {
            omega_bounds: (0.05, 3.0),
            omega_fixed: None,
            min_dof: 1,
            min_decades: 1.0,
            max_omega_rel_error: 0.5,
            max_dropped: usize::MAX,
            origin: false,
            origin_bound: 0.5,
        }
    }
}

impl AsymptoticOptions {
    fn validate(&self) -> Result<()> {
        let (lo, hi) = self.omega_bounds;
        check_arg("omega_bounds.0", lo, "finite and > 0", lo > 0.0)?;
        check_arg("omega_bounds.1", hi, "finite and > omega_bounds.0", hi > lo)?;
        if let Some(w) = self.omega_fixed {
            check_arg("omega_fixed", w, "finite and > 0", w > 0.0)?;
        }
        check_arg(
            "min_decades",
            self.min_decades,
            "finite and ≥ 0",
            self.min_decades >= 0.0,
        )?;
        check_arg(
            "max_omega_rel_error",
            self.max_omega_rel_error,
            "finite and > 0",
            self.max_omega_rel_error > 0.0,
        )?;
        check_arg(
            "origin_bound",
            self.origin_bound,
            "in (0, 1)",
            self.origin_bound > 0.0 && self.origin_bound < 1.0,
        )
    }
}

/// One corrected fit.
#[derive(Clone, Debug, PartialEq)]
pub struct CorrectedFit {
    /// The form.
    pub form: Form,
    /// ω was free.
    pub omega_free: bool,
    /// The asymptotic exponent x and its 1σ.
    pub x: f64,
    /// 1σ of x.
    pub x_error: f64,
    /// ω (fitted or held) and its 1σ (0 if held).
    pub omega: f64,
    /// 1σ of ω (0 if held).
    pub omega_error: f64,
    /// The correction amplitude B (for the running form, the fitted ωB divided by ω).
    pub amplitude: f64,
    /// 1σ of B.
    pub amplitude_error: f64,
    /// Values fitted (rungs for the direct form, pairs for the running form).
    pub points: usize,
    /// Degrees of freedom.
    pub dof: usize,
    /// Smallest and largest |l| of the rungs used.
    pub l_range: (f64, f64),
    /// χ²/dof (unit weights if unweighted).
    pub reduced_chi2: f64,
    /// The solver converged (always for linear fits).
    pub converged: bool,
    /// ω ended at one of its bounds.
    pub omega_at_bound: bool,
    /// The load origin δ (in units of l; 0 for the forms that hold it at L_c).
    pub origin: f64,
    /// 1σ of δ (0 if held).
    pub origin_error: f64,
    /// δ ended at one of its bounds ([`AsymptoticOptions::origin_bound`]).
    pub origin_at_bound: bool,
}

/// Why a fit does not constrain the asymptotic exponent.
#[derive(Clone, Debug, PartialEq)]
pub enum WindowIssue {
    /// Fewer values than free parameters + `min_dof`.
    TooFewPoints {
        /// Values available (rungs or pairs).
        got: usize,
        /// Values needed.
        needed: usize,
    },
    /// The |l| range spans fewer decades than `min_decades`.
    RangeTooNarrow {
        /// log10(|l|_max/|l|_min).
        decades: f64,
        /// The minimum.
        needed: f64,
    },
    /// ω is not determined by the data.
    OmegaUnconstrained {
        /// Fitted ω.
        omega: f64,
        /// Its 1σ.
        error: f64,
        /// It ended at a bound.
        at_bound: bool,
    },
    /// The load origin is not determined by the data (an origin fit whose δ ended at its bound
    /// or has no finite error).
    OriginUnconstrained {
        /// Fitted δ.
        delta: f64,
        /// Its 1σ.
        error: f64,
        /// The bound (± this).
        bound: f64,
    },
    /// The fit did not converge or gave a non-finite error.
    NotConverged,
    /// The fit failed outright.
    Failed(String),
}

impl std::fmt::Display for WindowIssue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            WindowIssue::TooFewPoints { got, needed } => write!(
                f,
                "too few points: {got} values, at least {needed} needed (free parameters + min_dof)"
            ),
            WindowIssue::RangeTooNarrow { decades, needed } => write!(
                f,
                "|l| range too narrow: {decades:.2} decades, at least {needed} needed"
            ),
            WindowIssue::OmegaUnconstrained {
                omega,
                error,
                at_bound,
            } => write!(
                f,
                "ω unconstrained: ω = {omega:.3} ± {error:.3}{}",
                if *at_bound { " (at a bound)" } else { "" }
            ),
            WindowIssue::OriginUnconstrained {
                delta,
                error,
                bound,
            } => write!(
                f,
                "load origin unconstrained: δ = {delta:.3e} ± {error:.3e} (bound ±{bound:.3e})"
            ),
            WindowIssue::NotConverged => write!(f, "fit not converged or error not finite"),
            WindowIssue::Failed(e) => write!(f, "fit failed: {e}"),
        }
    }
}

/// Log-space data of a ladder: (|l|, ln y, σ of ln y if every σ_y > 0).
fn log_data(points: &[ScalingPoint]) -> (Vec<f64>, Vec<f64>, Option<Vec<f64>>) {
    let a: Vec<f64> = points.iter().map(|p| p.l.abs()).collect();
    let ly: Vec<f64> = points.iter().map(|p| p.y.ln()).collect();
    let s = points
        .iter()
        .all(|p| p.sigma > 0.0)
        .then(|| points.iter().map(|p| p.sigma / p.y).collect());
    (a, ly, s)
}

/// The error factor of the convention in the module docs: weighted fits scale up only.
fn error_factor(f: &FitResult, weighted: bool) -> f64 {
    if weighted && f.dof > 0 {
        f.reduced_chi2().sqrt().max(1.0)
    } else {
        1.0
    }
}

/// The ω grid of the starting-value profile: 40 values spread evenly in ln ω over the bounds.
fn omega_grid(bounds: (f64, f64)) -> impl Iterator<Item = f64> {
    let (lo, hi) = bounds;
    (0..40).map(move |k| lo * (hi / lo).powf((k as f64 + 0.5) / 40.0))
}

/// Linear least squares with columns [1, c1, c2] over a profile of ω (or at the fixed one):
/// the (χ², ω, params) of the best; `col1` is fixed, `col2(ω)` varies.
fn profile(
    omega: Omega,
    bounds: (f64, f64),
    col1: &[f64],
    col2: &dyn Fn(f64) -> Vec<f64>,
    y: &[f64],
    sigma: Option<&[f64]>,
) -> Option<(f64, f64, Vec<f64>)> {
    let ones = vec![1.0; y.len()];
    let grid: Vec<f64> = match omega {
        Omega::Fixed(w) => vec![w],
        Omega::Free => omega_grid(bounds).collect(),
    };
    grid.into_iter()
        .filter_map(|w| {
            let c2 = col2(w);
            let f =
                linear_least_squares(&[&ones, col1, &c2], y, sigma, ErrorScale::Absolute).ok()?;
            Some((f.chi2, w, f.params))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
}

fn check_omega(omega: Omega, bounds: (f64, f64)) -> Result<()> {
    if let Omega::Fixed(w) = omega {
        check_arg("omega (fixed)", w, "finite and > 0", w > 0.0)?;
    }
    let (lo, hi) = bounds;
    check_arg("omega_bounds", lo, "0 < lower < upper", lo > 0.0 && hi > lo)
}

/// The starting values of a direct fit (module docs): the linearised model
/// `ln y ≈ ln A + x ln|l| + B|l|^ω` solved by linear least squares at the held ω or, for a free ω,
/// at the best of the grid over `bounds` (`la` = ln|l|); returns that ω and (ln A, x, B).
fn linearised_start(
    a: &[f64],
    la: &[f64],
    ly: &[f64],
    sigma: Option<&[f64]>,
    omega: Omega,
    bounds: (f64, f64),
) -> Result<(f64, Vec<f64>)> {
    let col2 = |w: f64| a.iter().map(|v| v.powf(w)).collect::<Vec<f64>>();
    let (_, w0, p) = profile(omega, bounds, la, &col2, ly, sigma).ok_or_else(|| {
        FitError::Singular("the linearised corrected power law has no solution".into())
    })?;
    Ok((w0, p))
}

/// The solver options of a four-parameter direct fit: ln A, x, B free, the fourth (ω, or the
/// origin form's δ/|l|_min) as `fourth` says; absolute errors when weighted, else scaled by the
/// misfit (module docs).
fn direct_options(fourth: ParamSpec, name: &'static str, weighted: bool) -> NonlinearOptions {
    NonlinearOptions {
        params: vec![ParamSpec::FREE, ParamSpec::FREE, ParamSpec::FREE, fourth],
        scale: if weighted {
            ErrorScale::Absolute
        } else {
            ErrorScale::ReducedChi2
        },
        names: vec!["lnA", "x", "B", name],
        ..Default::default()
    }
}

/// Fits `y = A|l|^x (1 + B|l|^ω)` to the rungs (the direct form; module docs). Errors: invalid
/// points (as [`crate::local_slopes`] says), fewer rungs than free parameters + 1, or a failed
/// fit. Whether the fit constrains x is judged by [`asymptotic_estimate`], not here.
pub fn fit_corrected_power_law(
    points: &[ScalingPoint],
    omega: Omega,
    bounds: (f64, f64),
) -> Result<CorrectedFit> {
    check_omega(omega, bounds)?;
    local_slopes(points)?; // validates the ladder
    let (a, ly, sl) = log_data(points);
    let la: Vec<f64> = a.iter().map(|v| v.ln()).collect();
    let (w0, p) = linearised_start(&a, &la, &ly, sl.as_deref(), omega, bounds)?;
    let free = matches!(omega, Omega::Free);
    let spec_w = if free {
        ParamSpec {
            fixed: false,
            lower: Some(bounds.0),
            upper: Some(bounds.1),
        }
    } else {
        ParamSpec::FIXED
    };
    let opts = direct_options(spec_w, "omega", sl.is_some());
    // ln(1 + B|l|^ω) is undefined for 1 + B|l|^ω ≤ 0: a large finite penalty keeps MPFIT away
    let model =
        |t: f64, q: &[f64]| q[0] + q[1] * t + (1.0 + q[2] * t.exp().powf(q[3])).max(1e-300).ln();
    let f = nonlinear_fit(
        model,
        &la,
        &ly,
        sl.as_deref(),
        &[p[0], p[1], p[2], w0],
        &opts,
    )?;
    let k = error_factor(&f, sl.is_some());
    let at_bound = free && (f.params[3] - bounds.0).min(bounds.1 - f.params[3]) < 1e-9;
    Ok(CorrectedFit {
        omega_free: free,
        omega_at_bound: at_bound,
        ..four_parameter_fit(Form::Direct, &f, k, &a)
    })
}

/// A fit of [`direct_options`]' four parameters (ln A, x, B, ω) as a [`CorrectedFit`]: errors
/// times `k`, ω not free and not at a bound, the origin at L_c; the callers adjust the rest.
fn four_parameter_fit(form: Form, f: &FitResult, k: f64, a: &[f64]) -> CorrectedFit {
    CorrectedFit {
        form,
        omega_free: false,
        x: f.params[1],
        x_error: k * f.errors[1],
        omega: f.params[3],
        omega_error: k * f.errors[3],
        amplitude: f.params[2],
        amplitude_error: k * f.errors[2],
        points: a.len(),
        dof: f.dof,
        l_range: l_range(a),
        reduced_chi2: f.reduced_chi2(),
        converged: f.status.converged,
        omega_at_bound: false,
        origin: 0.0,
        origin_error: 0.0,
        origin_at_bound: false,
    }
}

fn l_range(a: &[f64]) -> (f64, f64) {
    (
        a.iter().copied().fold(f64::INFINITY, f64::min),
        a.iter().copied().fold(0.0, f64::max),
    )
}

/// Fits the running exponents of the rungs by `x_eff = x + ωB u_ω` (the running form; module
/// docs). Errors as [`fit_corrected_power_law`].
pub fn fit_running_exponent(
    points: &[ScalingPoint],
    omega: Omega,
    bounds: (f64, f64),
) -> Result<CorrectedFit> {
    check_omega(omega, bounds)?;
    let slopes: Vec<RunningSlope> = local_slopes(points)?;
    let s: Vec<f64> = slopes.iter().map(|r| r.value).collect();
    let sig: Option<Vec<f64>> = slopes
        .iter()
        .all(|r| r.fit_error > 0.0)
        .then(|| slopes.iter().map(|r| r.fit_error).collect());
    let col2 = |w: f64| slopes.iter().map(|r| r.u_omega(w)).collect::<Vec<f64>>();
    let ones = vec![1.0; s.len()];
    let scale = if sig.is_some() {
        ErrorScale::Absolute
    } else {
        ErrorScale::ReducedChi2
    };
    let free = matches!(omega, Omega::Free);
    let (x, xe, w, we, c, ce, f) = match omega {
        Omega::Fixed(w) => {
            let f = linear_least_squares(&[&ones, &col2(w)], &s, sig.as_deref(), scale)?;
            let k = error_factor(&f, sig.is_some());
            let (x, xe, c, ce) = (f.params[0], k * f.errors[0], f.params[1], k * f.errors[1]);
            (x, xe, w, 0.0, c, ce, f)
        }
        Omega::Free => {
            let (_, w0, p) = omega_grid(bounds)
                .filter_map(|w| {
                    let f =
                        linear_least_squares(&[&ones, &col2(w)], &s, sig.as_deref(), scale).ok()?;
                    Some((f.chi2, w, f.params))
                })
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .ok_or_else(|| FitError::Singular("no ω gives a determined running fit".into()))?;
            let idx: Vec<f64> = (0..slopes.len()).map(|i| i as f64).collect();
            let opts = NonlinearOptions {
                params: vec![
                    ParamSpec::FREE,
                    ParamSpec::FREE,
                    ParamSpec {
                        fixed: false,
                        lower: Some(bounds.0),
                        upper: Some(bounds.1),
                    },
                ],
                scale,
                names: vec!["x", "omegaB", "omega"],
                ..Default::default()
            };
            let model = |i: f64, q: &[f64]| q[0] + q[1] * slopes[i as usize].u_omega(q[2]);
            let f = nonlinear_fit(model, &idx, &s, sig.as_deref(), &[p[0], p[1], w0], &opts)?;
            let k = error_factor(&f, sig.is_some());
            let (x, xe, c, ce) = (f.params[0], k * f.errors[0], f.params[1], k * f.errors[1]);
            (x, xe, f.params[2], k * f.errors[2], c, ce, f)
        }
    };
    let a: Vec<f64> = points.iter().map(|p| p.l.abs()).collect();
    Ok(CorrectedFit {
        form: Form::Running,
        omega_free: free,
        x,
        x_error: xe,
        omega: w,
        omega_error: we,
        amplitude: c / w,
        amplitude_error: ce / w,
        points: s.len(),
        dof: f.dof,
        l_range: l_range(&a),
        reduced_chi2: f.reduced_chi2(),
        converged: f.status.converged,
        omega_at_bound: free && (w - bounds.0).min(bounds.1 - w) < 1e-9,
        origin: 0.0,
        origin_error: 0.0,
        origin_at_bound: false,
    })
}

/// Fits `y = A(|l| + δ)^x (1 + B|l|^ω)` with ω held at `omega` and |δ| ≤ `bound` · min|l| (the
/// origin form; module docs). Starts from the direct fixed-ω fit's linearised solution at δ = 0.
/// Errors as [`fit_corrected_power_law`], and `bound` outside (0, 1).
pub fn fit_origin_power_law(
    points: &[ScalingPoint],
    omega: f64,
    bound: f64,
) -> Result<CorrectedFit> {
    check_arg("omega (fixed)", omega, "finite and > 0", omega > 0.0)?;
    check_arg(
        "origin bound",
        bound,
        "in (0, 1)",
        bound > 0.0 && bound < 1.0,
    )?;
    local_slopes(points)?; // validates the ladder
    let (a, ly, sl) = log_data(points);
    let (a_min, _) = l_range(&a);
    // bounds are read only for a free ω
    let la: Vec<f64> = a.iter().map(|v| v.ln()).collect();
    let (_, p) = linearised_start(
        &a,
        &la,
        &ly,
        sl.as_deref(),
        Omega::Fixed(omega),
        (omega, omega),
    )?;
    let spec_d = ParamSpec {
        fixed: false,
        lower: Some(-bound),
        upper: Some(bound),
    };
    let opts = direct_options(spec_d, "delta/l_min", sl.is_some());
    // q[3] = δ/|l|_min ∈ [−bound, bound] keeps |l| + δ ≥ (1 − bound)|l|_min > 0; the correction
    // keeps the penalty of the direct form
    let model = |v: f64, q: &[f64]| {
        q[0] + q[1] * (v + q[3] * a_min).ln() + (1.0 + q[2] * v.powf(omega)).max(1e-300).ln()
    };
    let f = nonlinear_fit(
        model,
        &a,
        &ly,
        sl.as_deref(),
        &[p[0], p[1], p[2], 0.0],
        &opts,
    )?;
    let k = error_factor(&f, sl.is_some());
    Ok(CorrectedFit {
        omega,
        omega_error: 0.0,
        origin: f.params[3] * a_min,
        origin_error: k * f.errors[3] * a_min,
        origin_at_bound: bound - f.params[3].abs() < 1e-9,
        ..four_parameter_fit(Form::Origin, &f, k, &a)
    })
}

/// One fit of the estimate: its window, form and outcome.
#[derive(Clone, Debug, PartialEq)]
pub struct Variant {
    /// Rungs dropped from the large-|l| end.
    pub dropped: usize,
    /// The form.
    pub form: Form,
    /// ω free (else held at the estimate's `omega_fixed`).
    pub omega_free: bool,
    /// The fit if it was accepted, else why not.
    pub outcome: std::result::Result<CorrectedFit, WindowIssue>,
}

/// Result of [`asymptotic_estimate`].
#[derive(Clone, Debug, PartialEq)]
pub struct AsymptoticEstimate {
    /// The asymptotic exponent (the reference fit's x).
    pub value: f64,
    /// sqrt(stat_error² + spread²).
    pub error: f64,
    /// 1σ of the reference fit.
    pub stat_error: f64,
    /// max |x_v − x_ref| over all accepted fits.
    pub spread: f64,
    /// The same over the accepted fits of the reference's form and ω mode on narrower windows.
    pub range_spread: f64,
    /// The same over the accepted fits of other forms or ω modes on the widest window.
    pub form_spread: f64,
    /// The same over the accepted origin fits, every window ([`Form::Origin`]; NaN if none was
    /// accepted or [`AsymptoticOptions::origin`] is off). Part of `spread`.
    pub origin_spread: f64,
    /// More than one fit was accepted (else `spread` = 0 is not a measurement).
    pub spread_measured: bool,
    /// ω of the fixed-ω fits.
    pub omega_fixed: f64,
    /// Index of the reference fit in `variants`.
    pub reference: usize,
    /// Every fit tried, accepted or not.
    pub variants: Vec<Variant>,
}

impl AsymptoticEstimate {
    /// The reference fit.
    pub fn reference_fit(&self) -> &CorrectedFit {
        self.variants[self.reference]
            .outcome
            .as_ref()
            .expect("the reference is accepted")
    }
}

/// Why no asymptotic estimate could be made.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum AsymptoticError {
    /// Bad input or options.
    #[error("{0}")]
    Input(#[from] FitError),
    /// No fit on any window constrains the exponent.
    #[error("no window constrains the asymptotic exponent: {}", summary(.0))]
    Unconstrained(Vec<Variant>),
}

fn summary(v: &[Variant]) -> String {
    v.iter()
        .map(|v| {
            let why = match &v.outcome {
                Ok(_) => "accepted".to_string(),
                Err(e) => e.to_string(),
            };
            format!(
                "[{} largest |l| dropped, {:?}, ω {}: {why}]",
                v.dropped,
                v.form,
                if v.omega_free { "free" } else { "fixed" }
            )
        })
        .collect::<Vec<_>>()
        .join("; ")
}

/// Judges a fit as the module docs say: `Ok` if it constrains x.
fn judge(
    r: Result<CorrectedFit>,
    needed: usize,
    decades: f64,
    opts: &AsymptoticOptions,
) -> std::result::Result<CorrectedFit, WindowIssue> {
    let f = r.map_err(|e| match e {
        FitError::TooFewPoints { got, .. } => WindowIssue::TooFewPoints { got, needed },
        e => WindowIssue::Failed(e.to_string()),
    })?;
    if f.points < needed {
        return Err(WindowIssue::TooFewPoints {
            got: f.points,
            needed,
        });
    }
    if decades < opts.min_decades {
        return Err(WindowIssue::RangeTooNarrow {
            decades,
            needed: opts.min_decades,
        });
    }
    if !(f.converged && f.x_error.is_finite()) {
        return Err(WindowIssue::NotConverged);
    }
    if f.form == Form::Origin && (f.origin_at_bound || !f.origin_error.is_finite()) {
        let (a_min, _) = f.l_range;
        return Err(WindowIssue::OriginUnconstrained {
            delta: f.origin,
            error: f.origin_error,
            bound: opts.origin_bound * a_min,
        });
    }
    if f.omega_free
        && (f.omega_at_bound
            || !f.omega_error.is_finite()
            || f.omega_error > opts.max_omega_rel_error * f.omega)
    {
        return Err(WindowIssue::OmegaUnconstrained {
            omega: f.omega,
            error: f.omega_error,
            at_bound: f.omega_at_bound,
        });
    }
    Ok(f)
}

/// One window: the four fits (direct/running × ω free/fixed) and, with [`AsymptoticOptions::origin`],
/// the origin fit, judged. `omega_fixed` None skips the fixed-ω and origin fits (they are added
/// once ω is known).
fn fit_window(
    w: &[ScalingPoint],
    dropped: usize,
    omega_fixed: Option<f64>,
    opts: &AsymptoticOptions,
) -> Vec<Variant> {
    let a: Vec<f64> = w.iter().map(|p| p.l.abs()).collect();
    let (lo, hi) = l_range(&a);
    let decades = (hi / lo).log10();
    let fixed = omega_fixed.map(Omega::Fixed);
    let mut fits = vec![
        (Form::Direct, Some(Omega::Free)),
        (Form::Direct, fixed),
        (Form::Running, Some(Omega::Free)),
        (Form::Running, fixed),
    ];
    if opts.origin {
        fits.push((Form::Origin, fixed));
    }
    let mut out = Vec::new();
    for (form, omega) in fits {
        let Some(omega) = omega else { continue };
        let free = matches!(omega, Omega::Free);
        // free parameters: direct ln A, x, B (+ ω); running x, ωB (+ ω); origin ln A, x, B, δ;
        // the values fitted: the rungs, or for the running form the pairs
        let (k, values) = match form {
            Form::Direct => (3, w.len()),
            Form::Running => (2, w.len().saturating_sub(1)),
            Form::Origin => (4, w.len()),
        };
        let needed = k + usize::from(free) + opts.min_dof;
        let outcome = if values < needed {
            Err(WindowIssue::TooFewPoints {
                got: values,
                needed,
            })
        } else {
            let r = match (form, omega) {
                (Form::Direct, _) => fit_corrected_power_law(w, omega, opts.omega_bounds),
                (Form::Running, _) => fit_running_exponent(w, omega, opts.omega_bounds),
                (Form::Origin, Omega::Fixed(w0)) => fit_origin_power_law(w, w0, opts.origin_bound),
                (Form::Origin, Omega::Free) => unreachable!("the origin form holds ω"),
            };
            judge(r, needed, decades, opts)
        };
        out.push(Variant {
            dropped,
            form,
            omega_free: free,
            outcome,
        });
    }
    out
}

/// The asymptotic exponent of a ladder with corrections to scaling and an error bar that
/// includes the choice of fit range and form (module docs). Errors: invalid points or options
/// ([`AsymptoticError::Input`]), or no fit accepted on any window
/// ([`AsymptoticError::Unconstrained`], listing every fit and why it was rejected).
pub fn asymptotic_estimate(
    points: &[ScalingPoint],
    opts: &AsymptoticOptions,
) -> std::result::Result<AsymptoticEstimate, AsymptoticError> {
    opts.validate()?;
    local_slopes(points)?; // validates the ladder
    let mut pts = points.to_vec();
    pts.sort_by(|a, b| b.l.abs().total_cmp(&a.l.abs()));
    let windows: Vec<(usize, &[ScalingPoint])> = (0..pts.len().saturating_sub(1))
        .take(opts.max_dropped.saturating_add(1))
        .map(|d| (d, &pts[d..]))
        .collect();
    // ω for the fixed fits: given, or the direct free fit's on the widest window constraining it
    let omega_fixed = opts.omega_fixed.or_else(|| {
        windows.iter().find_map(|&(d, w)| {
            fit_window(w, d, None, opts)
                .into_iter()
                .find(|v| v.form == Form::Direct)
                .and_then(|v| v.outcome.ok())
                .map(|f| f.omega)
        })
    });
    let variants: Vec<Variant> = windows
        .iter()
        .flat_map(|&(d, w)| fit_window(w, d, omega_fixed, opts))
        .collect();
    let order = [
        (Form::Direct, true),
        (Form::Direct, false),
        (Form::Running, false),
        (Form::Running, true),
    ];
    let reference = variants
        .iter()
        .map(|v| v.dropped)
        .filter(|&d| variants.iter().any(|v| v.dropped == d && v.outcome.is_ok()))
        .min()
        .and_then(|d| {
            order.iter().find_map(|&(form, free)| {
                variants.iter().position(|v| {
                    v.dropped == d && v.form == form && v.omega_free == free && v.outcome.is_ok()
                })
            })
        });
    let Some(reference) = reference else {
        return Err(AsymptoticError::Unconstrained(variants));
    };
    let r = &variants[reference];
    let rf = r.outcome.as_ref().expect("accepted");
    let dev = |keep: &dyn Fn(&Variant) -> bool| {
        variants
            .iter()
            .filter(|v| keep(v))
            .filter_map(|v| v.outcome.as_ref().ok())
            .map(|f| (f.x - rf.x).abs())
            .fold(0.0, f64::max)
    };
    let spread = dev(&|_| true);
    let range_spread =
        dev(&|v| v.form == r.form && v.omega_free == r.omega_free && v.dropped != r.dropped);
    let form_spread = dev(&|v| v.dropped == r.dropped);
    let origin_spread = if variants
        .iter()
        .any(|v| v.form == Form::Origin && v.outcome.is_ok())
    {
        dev(&|v| v.form == Form::Origin)
    } else {
        f64::NAN
    };
    let accepted = variants.iter().filter(|v| v.outcome.is_ok()).count();
    Ok(AsymptoticEstimate {
        value: rf.x,
        error: rf.x_error.hypot(spread),
        stat_error: rf.x_error,
        spread,
        range_spread,
        form_spread,
        origin_spread,
        spread_measured: accepted > 1,
        omega_fixed: omega_fixed.unwrap_or(f64::NAN),
        reference,
        variants,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng, rngs::SmallRng};

    /// The issue's default ladder, |l| = 5e-2 … 1e-5 (1-2-5), signed.
    fn ladder(sign: f64) -> Vec<f64> {
        [
            5e-2, 2e-2, 1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4, 5e-5, 2e-5, 1e-5,
        ]
        .iter()
        .map(|a| sign * a)
        .collect()
    }

    /// y = A|l|^x (1 + B|l|^ω), with relative Gaussian noise `rel` (σ_y = rel·y, or 0).
    fn synthetic(x: f64, b: f64, w: f64, rel: f64, seed: u64) -> Vec<ScalingPoint> {
        let mut rng = SmallRng::seed_from_u64(seed);
        ladder(-1.0)
            .into_iter()
            .map(|l| {
                let (u, v): (f64, f64) = (rng.random(), rng.random());
                let g = (-2.0 * (1.0 - u).ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos();
                let y = 0.7 * l.abs().powf(x) * (1.0 + b * l.abs().powf(w));
                ScalingPoint::new(l, y * (1.0 + rel * g), rel * y)
            })
            .collect()
    }

    #[test]
    fn exact_data_give_the_exponent_and_omega() {
        // noise-free y = 0.7|l|^1.2 (1 + 0.8|l|^0.5) on both sides of L_c: the direct fit is the
        // exact model, so x and ω come back to the solver tolerance (1e-10 relative on χ² and
        // parameters; 1e-8 leaves room for the conditioning of 4 parameters)
        for sign in [-1.0, 1.0] {
            let p: Vec<ScalingPoint> = synthetic(1.2, 0.8, 0.5, 0.0, 1)
                .into_iter()
                .map(|q| ScalingPoint::new(sign * q.l.abs(), q.y, 0.0))
                .collect();
            let f = fit_corrected_power_law(&p, Omega::Free, (0.05, 3.0)).unwrap();
            assert!(
                (f.x - 1.2).abs() < 1e-8 && (f.omega - 0.5).abs() < 1e-6,
                "{f:?}"
            );
            assert!((f.amplitude - 0.8).abs() < 1e-6, "{f:?}");
            let e = asymptotic_estimate(&p, &AsymptoticOptions::default()).unwrap();
            let r = e.reference_fit();
            assert_eq!(
                (r.form, r.omega_free, e.variants[e.reference].dropped),
                (Form::Direct, true, 0)
            );
            assert!((e.value - 1.2).abs() < 1e-8, "{}", e.value);
            assert!((e.omega_fixed - 0.5).abs() < 1e-6);
            // the only spread is the running form's O(B²|l|^2ω) remainder: the local slope is
            // x + ωB u/(1 + B u) exactly, not x + ωB u; with B|l|^ω ≤ 0.18 it moves x by
            // ~1e-4 (measured 1.5e-4), so it is present but below 1e-3
            assert!(
                e.spread_measured && e.form_spread > 1e-6 && e.spread < 1e-3,
                "{e:?}"
            );
            assert!(e.error >= e.spread && e.error >= e.stat_error);
        }
    }

    /// y = 0.7 (|l| + δ)^x (1 + B|l|^ω) on the default ladder (l < 0), noise-free.
    fn shifted(x: f64, b: f64, w: f64, delta: f64) -> Vec<ScalingPoint> {
        ladder(-1.0)
            .into_iter()
            .map(|l| {
                let y = 0.7 * (l.abs() + delta).powf(x) * (1.0 + b * l.abs().powf(w));
                ScalingPoint::new(l, y, 0.0)
            })
            .collect()
    }

    #[test]
    fn the_origin_fit_recovers_a_shifted_origin() {
        // exact model at the true ω: x, B and δ come back to the solver's tolerance, for a shift
        // of 1 % and of 20 % of the smallest |l| (1e-5), of either sign
        for delta in [1e-7, -1e-7, 2e-6, -2e-6] {
            let p = shifted(1.2, 0.8, 0.5, delta);
            let f = fit_origin_power_law(&p, 0.5, 0.5).unwrap();
            assert_eq!(f.form, Form::Origin);
            assert!((f.x - 1.2).abs() < 1e-8, "δ {delta}: {f:?}");
            assert!((f.amplitude - 0.8).abs() < 1e-6, "δ {delta}: {f:?}");
            assert!((f.origin - delta).abs() < 1e-6 * 1e-5, "δ {delta}: {f:?}");
            assert!(f.converged && !f.origin_at_bound && f.origin_error.is_finite());
        }
        // no shift in the data: δ = 0 and the direct fixed-ω fit's x
        let p = shifted(1.2, 0.8, 0.5, 0.0);
        let f = fit_origin_power_law(&p, 0.5, 0.5).unwrap();
        let d = fit_corrected_power_law(&p, Omega::Fixed(0.5), (0.05, 3.0)).unwrap();
        assert!(
            f.origin.abs() < 1e-6 * 1e-5 && (f.x - d.x).abs() < 1e-7,
            "{f:?}"
        );
        // bad arguments name themselves
        let e = fit_origin_power_law(&p, 0.5, 1.0).unwrap_err().to_string();
        assert!(e.contains("origin bound"), "{e}");
    }

    /// The estimate with the origin form on, else the default options.
    fn with_origin(p: &[ScalingPoint]) -> AsymptoticEstimate {
        let opts = AsymptoticOptions {
            origin: true,
            ..Default::default()
        };
        asymptotic_estimate(p, &opts).unwrap()
    }

    #[test]
    fn the_origin_form_measures_the_bias_of_a_shifted_origin() {
        // y = 0.7(|l| + δ)^1.2 (1 + 0.8|l|^0.5) with δ = 2e-7 (2 % of the smallest |l|): the
        // running exponent falls by 1.2 δ (1/|l_lo| − 1/|l_hi|)/ln(l_hi/l_lo) ≈ 0.017 more at
        // 2e-5 → 1e-5 than the correction says, which the fits with the origin at L_c can only
        // read as a lower exponent
        let p = shifted(1.2, 0.8, 0.5, 2e-7);
        let off = asymptotic_estimate(&p, &AsymptoticOptions::default()).unwrap();
        assert!(off.variants.iter().all(|v| v.form != Form::Origin));
        assert!(off.origin_spread.is_nan());
        let on = with_origin(&p);
        // the reference fit is the same fit either way (the origin form is never the reference)
        assert_eq!(on.value, off.value);
        assert_eq!(on.reference_fit(), off.reference_fit());
        // the origin fits move towards the truth on every window (measured: x = 1.1897 on the
        // full ladder … 1.1981 on the deepest 5 rungs, δ = 0.8e-7 … 1.95e-7, the held ω being the
        // biased direct fit's 0.349 rather than 0.5), so the origin spread alone measures most
        // of the reference's bias (0.0108 of 0.0126)
        let bias = (off.value - 1.2).abs();
        assert!(bias > 0.01, "{off:?}");
        for v in on.variants.iter().filter(|v| v.form == Form::Origin) {
            match &v.outcome {
                Ok(f) => assert!(
                    (f.x - 1.2).abs() < bias && f.origin > 0.3 * 2e-7 && f.origin < 1.1 * 2e-7,
                    "{v:?}"
                ),
                Err(e) => assert!(matches!(e, WindowIssue::TooFewPoints { .. }), "{v:?}"),
            }
        }
        assert!(
            on.origin_spread > 0.75 * bias && on.spread >= on.origin_spread,
            "{on:?}"
        );
        assert!((on.value - 1.2).abs() <= on.error, "{on:?}");
        // without a shift in the data the origin form adds nothing: the fits are exact at the
        // held ω (the direct free fit's, 0.5 to 1e-6), δ = 0 and x = 1.2 to the solver tolerance
        let p = shifted(1.2, 0.8, 0.5, 0.0);
        let on = with_origin(&p);
        assert!(on.origin_spread < 1e-6, "{on:?}");
    }

    #[test]
    fn an_origin_beyond_its_bound_is_rejected_and_named() {
        // a shift of 80 % of the smallest |l| with the bound at 50 %: every origin fit that
        // reaches the smallest rung ends at its bound and is rejected, with the reason
        let p = shifted(1.2, 0.8, 0.5, 8e-6);
        let opts = AsymptoticOptions {
            origin: true,
            omega_fixed: Some(0.5),
            ..Default::default()
        };
        let e = asymptotic_estimate(&p, &opts).unwrap();
        let origin: Vec<&Variant> = e
            .variants
            .iter()
            .filter(|v| v.form == Form::Origin)
            .collect();
        assert!(!origin.is_empty());
        for v in origin {
            match &v.outcome {
                Err(WindowIssue::OriginUnconstrained { delta, bound, .. }) => {
                    assert!(
                        (delta.abs() - bound).abs() < 1e-9 * bound && *bound == 5e-6,
                        "{v:?}"
                    );
                    let msg = v.outcome.clone().unwrap_err().to_string();
                    assert!(msg.starts_with("load origin unconstrained: δ = "), "{msg}");
                }
                Err(WindowIssue::TooFewPoints { .. }) => {}
                other => panic!("{other:?}"),
            }
        }
        assert!(e.origin_spread.is_nan());
        let bad = AsymptoticOptions {
            origin_bound: 0.0,
            ..opts
        };
        let msg = asymptotic_estimate(&p, &bad).unwrap_err().to_string();
        assert!(msg.contains("origin_bound"), "{msg}");
    }

    #[test]
    fn noisy_data_are_covered_by_the_error_bar() {
        // 0.1 % Gaussian noise per rung, 50 seeds. The direct fit's stat error of x is ~6e-4
        // (measured: its ±1σ covers the truth in 74 % of 400 seeds, ±2σ in 96.5 %, i.e. it is
        // calibrated); the range/form spread adds the scatter of the narrower windows, so the
        // total bar is conservative. Asserted: it covers the truth at 1σ in ≥ 45 of 50 seeds (a
        // merely calibrated bar would manage ~34), its median is below the issue's target 0.005
        // (measured 0.003), and the reference fit's ω is within 2σ of 0.5 in ≥ 43 of 50 (expected
        // 47.7 for a Gaussian, binomial sd 1.5: 43 is 3 sd below)
        let (mut covered, mut omega_ok, mut errors) = (0, 0, Vec::new());
        for seed in 0..50 {
            let p = synthetic(1.2, 0.8, 0.5, 1e-3, seed);
            let e = asymptotic_estimate(&p, &AsymptoticOptions::default()).unwrap();
            assert!(
                e.stat_error < e.error && e.spread_measured,
                "seed {seed}: {e:?}"
            );
            covered += usize::from((e.value - 1.2).abs() <= e.error);
            let r = e.reference_fit();
            omega_ok += usize::from((r.omega - 0.5).abs() <= 2.0 * r.omega_error);
            errors.push(e.error);
        }
        errors.sort_by(f64::total_cmp);
        assert!(covered >= 45, "{covered}/50 covered");
        assert!(omega_ok >= 43, "{omega_ok}/50 ω within 2σ");
        assert!(errors[25] < 0.005, "median error {}", errors[25]);
    }

    #[test]
    fn a_pure_window_fit_is_biased() {
        // the paper's window 0.002 ≤ |l| ≤ 0.02 fitted by a pure power law, on the same exact
        // data: the slope picks up the correction, by B cov(|l|^ω, ln|l|)/var(ln|l|) to first
        // order (an independent computation: the regression of B|l|^ω on ln|l|). With B|l|^ω ≤
        // 0.11 on the window, ln(1 + z) = z − z²/2 differs from z by ≤ 6 %, so 10 % tolerance
        let (b, w) = (0.8, 0.5);
        let all = synthetic(1.2, b, w, 0.0, 1);
        let win: Vec<ScalingPoint> = all
            .iter()
            .copied()
            .filter(|p| (0.002..=0.02).contains(&p.l.abs()))
            .collect();
        assert_eq!(win.len(), 4);
        let x: Vec<f64> = win.iter().map(|p| p.l.abs()).collect();
        let y: Vec<f64> = win.iter().map(|p| p.y).collect();
        let pure = crate::power_law_fit(&x, &y, None, ErrorScale::ReducedChi2).unwrap();
        let bias = pure.params[1] - 1.2;
        let lx: Vec<f64> = x.iter().map(|v| v.ln()).collect();
        let corr: Vec<f64> = x.iter().map(|v| b * v.powf(w)).collect();
        let first = crate::linear_fit(&lx, &corr, None, ErrorScale::ReducedChi2).unwrap();
        assert!(
            (bias / first.params[1] - 1.0).abs() < 0.1,
            "{bias} vs {}",
            first.params[1]
        );
        // the bias is 0.031 (1.231 instead of 1.2): 3 times the paper's quoted ±0.01 and 8.6
        // times the window fit's own error bar, which sees only the (small) curvature
        assert!(bias > 0.025 && bias < 0.04, "{bias}");
        assert!(bias > 5.0 * pure.errors[1], "{pure:?}");
        // the corrections fit on the full ladder is unbiased within its error bar, which is
        // more than 30 times smaller than the window bias
        let e = asymptotic_estimate(&all, &AsymptoticOptions::default()).unwrap();
        assert!(
            (e.value - 1.2).abs() <= e.error && 30.0 * e.error < bias,
            "{e:?}"
        );
    }

    #[test]
    fn too_small_windows_are_detected_and_reported() {
        let all = synthetic(1.2, 0.8, 0.5, 1e-3, 3);
        let opts = AsymptoticOptions::default();
        // the paper's four rungs: too few for 3–4 parameters with a degree of freedom left
        let win: Vec<ScalingPoint> = all
            .iter()
            .copied()
            .filter(|p| (0.002..=0.02).contains(&p.l.abs()))
            .collect();
        let msg = match asymptotic_estimate(&win, &opts) {
            Err(AsymptoticError::Unconstrained(v)) => {
                assert!(v.iter().all(|v| matches!(
                    v.outcome,
                    Err(WindowIssue::TooFewPoints { .. })
                        | Err(WindowIssue::OmegaUnconstrained { .. })
                )));
                AsymptoticError::Unconstrained(v).to_string()
            }
            other => panic!("{other:?}"),
        };
        assert!(
            msg.contains("too few points: 4 values, at least 5 needed"),
            "{msg}"
        );
        // eight rungs within half a decade: enough points, too narrow a range
        let narrow: Vec<ScalingPoint> = (0..8)
            .map(|k| {
                let a = 1e-3 * 10f64.powf(k as f64 / 16.0);
                ScalingPoint::new(-a, a.powf(1.2) * (1.0 + 0.8 * a.sqrt()), 0.0)
            })
            .collect();
        let e = asymptotic_estimate(&narrow, &opts).unwrap_err().to_string();
        assert!(
            e.contains("|l| range too narrow: 0.44 decades, at least 1 needed"),
            "{e}"
        );
        // no correction in the data (B = 0) and noise: ω cannot be determined; with ω held
        // (e.g. from another observable) the fixed-ω fits still constrain x
        let pure = synthetic(1.2, 0.0, 0.5, 1e-3, 4);
        let e = asymptotic_estimate(&pure, &opts).unwrap_err().to_string();
        assert!(e.contains("ω unconstrained"), "{e}");
        let held = AsymptoticOptions {
            omega_fixed: Some(0.5),
            ..opts.clone()
        };
        let e = asymptotic_estimate(&pure, &held).unwrap();
        assert!(
            !e.reference_fit().omega_free && (e.value - 1.2).abs() < 2.0 * e.error,
            "{e:?}"
        );
        assert!(
            asymptotic_estimate(
                &pure,
                &AsymptoticOptions {
                    min_decades: -1.0,
                    ..opts
                }
            )
            .is_err()
        );
    }
}
