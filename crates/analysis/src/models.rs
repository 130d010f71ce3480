//! The model fits of the near-critical study, each with a data-driven starting point so that no
//! caller has to guess one.
//!
//! | fit | model | parameters |
//! |---|---|---|
//! | [`fit_sqrt_onset`] | `F(r) = A √(r − r_c)` for r > r_c, 0 below | `A`, `r_c` |
//! | [`fit_hertz`] | `p(x) = p0 √(1 − ((x − x0)/a)²)` for \|x − x0\| < a, 0 outside | `p0`, `a`, `x0` |
//! | [`fit_saddle_gap`] | `g(L) = A (L_c − L)^ζ` for L < L_c, 0 above | `A`, `L_c`, `zeta` |
//! | [`fit_power_law_offset`] | `y = y0 + A x^β`, x > 0 | `y0`, `A`, `beta` |
//!
//! All return a [`FitResult`]; errors follow the [`ErrorScale`] passed (use `ReducedChi2` or
//! `Auto` without σ for noise-free simulation data: the model misfit then sets the error bars).

use crate::error::{FitError, Result, check_arg, check_xy};
use crate::fit::{ErrorScale, FitResult};
use crate::linear::{linear_fit, polynomial_fit};
use crate::nonlinear::{NonlinearOptions, ParamSpec, nonlinear_fit};

fn chi2_of(model: impl Fn(f64) -> f64, x: &[f64], y: &[f64], sigma: Option<&[f64]>) -> f64 {
    x.iter()
        .zip(y)
        .enumerate()
        .map(|(i, (&xi, &yi))| {
            let s = sigma.map_or(1.0, |s| s[i]);
            let d = (yi - model(xi)) / s;
            d * d
        })
        .sum()
}

fn subset(idx: &[usize], v: &[f64]) -> Vec<f64> {
    idx.iter().map(|&i| v[i]).collect()
}

/// `A √(max(r − r_c, 0))`.
pub fn sqrt_onset(r: f64, a: f64, r_c: f64) -> f64 {
    a * (r - r_c).max(0.0).sqrt()
}

/// Fits the contact-line force profile `F(r) = A √(r − r_c)` (zero for r ≤ r_c) and locates the
/// contact line `r_c` below grid resolution.
///
/// Only the loaded samples (`F > 0`) are fitted; samples with `F ≤ 0` (outside the contact)
/// are ignored. Including them would put cusps into χ²: a sample just outside the edge whose
/// value is slightly negative makes χ² rise like `√(r_k − r_c)` as the edge passes it, a spurious
/// local minimum on which Levenberg–Marquardt stalls. The edge is located by the shape of the
/// loaded samples. The contact region must lie at `r > r_c`; for the mirror case pass `−r`
/// and negate `r_c`. Start: a straight-line fit of `F²` against `r` (`F² = A²(r − r_c)`).
/// Parameters `["A", "r_c"]`; dof counts the loaded samples only.
///
/// Errors: fewer than 2 samples with `F > 0` (3 for `ReducedChi2`), or F² not increasing with r.
pub fn fit_sqrt_onset(
    r: &[f64],
    f: &[f64],
    sigma: Option<&[f64]>,
    scale: ErrorScale,
) -> Result<FitResult> {
    check_xy("a square-root onset", r, f, sigma, 2)?;
    let pos: Vec<usize> = (0..r.len()).filter(|&i| f[i] > 0.0).collect();
    if pos.len() < 2 {
        return Err(FitError::TooFewPoints {
            what: "a square-root onset (samples with F > 0)",
            got: pos.len(),
            needed: 2,
        });
    }
    let rp = subset(&pos, r);
    let f2: Vec<f64> = pos.iter().map(|&i| f[i] * f[i]).collect();
    let start = linear_fit(&rp, &f2, None, ErrorScale::Absolute)?;
    let (b, s) = (start.params[0], start.params[1]);
    if s.is_nan() || s <= 0.0 {
        return Err(FitError::NoInitialGuess(format!(
            "F² does not increase with r (slope {s:.3e}); the contact side must be at r > r_c"
        )));
    }
    let p0 = [s.sqrt(), -b / s];
    let opts = NonlinearOptions {
        params: vec![ParamSpec::at_least(0.0), ParamSpec::FREE],
        scale,
        names: vec!["A", "r_c"],
        ..Default::default()
    };
    let fp = subset(&pos, f);
    let sp = sigma.map(|s| subset(&pos, s));
    nonlinear_fit(
        |x, p| sqrt_onset(x, p[0], p[1]),
        &rp,
        &fp,
        sp.as_deref(),
        &p0,
        &opts,
    )
}

/// `p0 √(max(1 − ((x − x0)/a)², 0))` (0 for a ≤ 0).
pub fn hertz_profile(x: f64, p0: f64, a: f64, x0: f64) -> f64 {
    if a <= 0.0 {
        return 0.0;
    }
    let u = (x - x0) / a;
    p0 * (1.0 - u * u).max(0.0).sqrt()
}

/// Fits a Hertzian pressure profile `p(x) = p0 √(1 − ((x − x0)/a)²)` (zero outside the contact)
/// to samples along a line: the half-width `a` locates the contact edge below grid resolution.
///
/// Only the loaded samples (`p > 0`) are fitted, for the reason given at [`fit_sqrt_onset`];
/// dof counts them only. `x0 = Some(c)` holds the centre at `c` (e.g. on a symmetry axis);
/// `None` fits it. Start: a
/// parabola fitted to `p²` over the samples with `p > 0` (`p² = p0² (1 − (x − x0)²/a²)`), falling
/// back to the extent and maximum of the loaded samples. Parameters `["p0", "a", "x0"]`
/// (`x0` has zero error when fixed).
///
/// Errors: fewer than 3 samples with `p > 0` (2 with `x0` fixed), non-finite input.
pub fn fit_hertz(
    x: &[f64],
    p: &[f64],
    sigma: Option<&[f64]>,
    x0: Option<f64>,
    scale: ErrorScale,
) -> Result<FitResult> {
    check_xy("a Hertz profile", x, p, sigma, 2)?;
    if let Some(c) = x0 {
        check_arg("x0", c, "finite", true)?;
    }
    let pos: Vec<usize> = (0..x.len()).filter(|&i| p[i] > 0.0).collect();
    let needed = if x0.is_some() { 2 } else { 3 };
    if pos.len() < needed {
        return Err(FitError::TooFewPoints {
            what: "a Hertz profile (samples with p > 0)",
            got: pos.len(),
            needed,
        });
    }
    let xp = subset(&pos, x);
    let p2: Vec<f64> = pos.iter().map(|&i| p[i] * p[i]).collect();
    // Parabola through p²: p² = c0 + c1 x + c2 x².
    let from_parabola = || -> Option<[f64; 3]> {
        match x0 {
            Some(c) => {
                let u2: Vec<f64> = xp.iter().map(|v| (v - c) * (v - c)).collect();
                let f = linear_fit(&u2, &p2, None, ErrorScale::Absolute).ok()?;
                let (d0, d2) = (f.params[0], f.params[1]);
                (d0 > 0.0 && d2 < 0.0).then(|| [d0.sqrt(), (-d0 / d2).sqrt(), c])
            }
            None => {
                let f = polynomial_fit(&xp, &p2, None, 2, ErrorScale::Absolute).ok()?;
                let (c0, c1, c2) = (f.params[0], f.params[1], f.params[2]);
                if c2 >= 0.0 {
                    return None;
                }
                let xc = -c1 / (2.0 * c2);
                let pp = c0 - c1 * c1 / (4.0 * c2);
                (pp > 0.0).then(|| [pp.sqrt(), (-pp / c2).sqrt(), xc])
            }
        }
    };
    let start = from_parabola().filter(|s| s.iter().all(|v| v.is_finite()));
    let start = start.unwrap_or_else(|| {
        let pmax = pos.iter().map(|&i| p[i]).fold(0.0, f64::max);
        let (lo, hi) = xp
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        let c = x0.unwrap_or(0.5 * (lo + hi));
        let half = (hi - c).max(c - lo).max(f64::MIN_POSITIVE);
        [pmax, half * 1.05, c]
    });
    let opts = NonlinearOptions {
        params: vec![
            ParamSpec::at_least(0.0),
            ParamSpec::at_least(0.0),
            if x0.is_some() {
                ParamSpec::FIXED
            } else {
                ParamSpec::FREE
            },
        ],
        scale,
        names: vec!["p0", "a", "x0"],
        ..Default::default()
    };
    let pp = subset(&pos, p);
    let sp = sigma.map(|s| subset(&pos, s));
    nonlinear_fit(
        |t, q| hertz_profile(t, q[0], q[1], q[2]),
        &xp,
        &pp,
        sp.as_deref(),
        &start,
        &opts,
    )
}

/// `A · max(L_c − L, 0)^ζ`.
pub fn saddle_gap(load: f64, a: f64, l_c: f64, zeta: f64) -> f64 {
    a * (l_c - load).max(0.0).powf(zeta)
}

/// Fits the closing saddle gap `g_s(L) = A (L_c − L)^ζ` with `L_c` free: the critical load by
/// extrapolation, below the resolution of the load steps.
///
/// `L_c` is bounded below by the largest load at which the gap is still open (`g > 0`): the gap
/// cannot be open above the critical load. If the fit ends on that bound, `status.pegged` is 1
/// and `L_c` carries no error bar: the data do not determine it. Start: profile over `L_c` (71
/// trial values at logarithmically spaced distances above the largest open load, each with a
/// straight-line fit of ln g against ln(L_c − L)), the best by χ². Parameters
/// `["A", "L_c", "zeta"]`.
///
/// Errors: fewer than 3 samples with `g > 0` (4 for `ReducedChi2`), all loads equal.
pub fn fit_saddle_gap(
    load: &[f64],
    gap: &[f64],
    sigma: Option<&[f64]>,
    scale: ErrorScale,
) -> Result<FitResult> {
    check_xy("a saddle-gap power law", load, gap, sigma, 3)?;
    let open: Vec<usize> = (0..load.len()).filter(|&i| gap[i] > 0.0).collect();
    if open.len() < 3 {
        return Err(FitError::TooFewPoints {
            what: "a saddle-gap power law (samples with g > 0)",
            got: open.len(),
            needed: 3,
        });
    }
    let lo = open.iter().map(|&i| load[i]).fold(f64::INFINITY, f64::min);
    let hi = open
        .iter()
        .map(|&i| load[i])
        .fold(f64::NEG_INFINITY, f64::max);
    let span = hi - lo;
    if span.is_nan() || span <= 0.0 {
        return Err(FitError::NoInitialGuess(format!(
            "all open-gap samples are at the same load {hi}; L_c cannot be extrapolated"
        )));
    }
    let go = subset(&open, gap);
    let lg: Vec<f64> = go.iter().map(|g| g.ln()).collect();
    let ls: Option<Vec<f64>> = sigma.map(|s| open.iter().map(|&i| s[i] / gap[i]).collect());
    let mut best: Option<(f64, [f64; 3])> = None;
    for k in 0..=70 {
        let l_c = hi + span * 10f64.powf(-6.0 + 7.0 * k as f64 / 70.0);
        let lx: Vec<f64> = open.iter().map(|&i| (l_c - load[i]).ln()).collect();
        let Ok(f) = linear_fit(&lx, &lg, ls.as_deref(), ErrorScale::Absolute) else {
            continue;
        };
        let (a, zeta) = (f.params[0].exp(), f.params[1]);
        let c2 = chi2_of(|l| saddle_gap(l, a, l_c, zeta), load, gap, sigma);
        if c2.is_finite() && best.is_none_or(|(b, _)| c2 < b) {
            best = Some((c2, [a, l_c, zeta]));
        }
    }
    let Some((_, start)) = best else {
        return Err(FitError::NoInitialGuess(
            "no trial L_c gave a finite log-log fit".into(),
        ));
    };
    let opts = NonlinearOptions {
        params: vec![
            ParamSpec::at_least(0.0),
            ParamSpec::at_least(hi),
            ParamSpec::FREE,
        ],
        scale,
        names: vec!["A", "L_c", "zeta"],
        ..Default::default()
    };
    nonlinear_fit(
        |l, q| saddle_gap(l, q[0], q[1], q[2]),
        load,
        gap,
        sigma,
        &start,
        &opts,
    )
}

/// Fits `y = y0 + A x^β` (x > 0). Start: profile over β ∈ [−4, 4] (step 0.02, skipping |β| < 0.01
/// where `x^β` and the offset are degenerate), each a linear fit of (y0, A). Parameters
/// `["y0", "A", "beta"]`.
///
/// Errors: x ≤ 0, fewer than 3 points (4 for `ReducedChi2`).
pub fn fit_power_law_offset(
    x: &[f64],
    y: &[f64],
    sigma: Option<&[f64]>,
    scale: ErrorScale,
) -> Result<FitResult> {
    check_xy("a power law with offset", x, y, sigma, 3)?;
    if let Some(index) = x.iter().position(|&v| v <= 0.0) {
        return Err(FitError::OutOfRange {
            what: "x",
            index,
            value: x[index],
            allowed: "> 0 for a power law",
        });
    }
    let ones = vec![1.0; x.len()];
    let mut best: Option<(f64, [f64; 3])> = None;
    for k in 0..=400 {
        let beta = -4.0 + 0.02 * k as f64;
        if beta.abs() < 0.01 {
            continue;
        }
        let xb: Vec<f64> = x.iter().map(|v| v.powf(beta)).collect();
        let Ok(f) =
            crate::linear::linear_least_squares(&[&ones, &xb], y, sigma, ErrorScale::Absolute)
        else {
            continue;
        };
        if f.chi2.is_finite() && best.is_none_or(|(b, _)| f.chi2 < b) {
            best = Some((f.chi2, [f.params[0], f.params[1], beta]));
        }
    }
    let Some((_, start)) = best else {
        return Err(FitError::NoInitialGuess(
            "no trial exponent gave a determined linear fit".into(),
        ));
    };
    let opts = NonlinearOptions {
        scale,
        names: vec!["y0", "A", "beta"],
        ..Default::default()
    };
    nonlinear_fit(
        |t, q| q[0] + q[1] * t.powf(q[2]),
        x,
        y,
        sigma,
        &start,
        &opts,
    )
}
